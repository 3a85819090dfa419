#!/usr/bin/env bash
# Installs every Debian 12 package TexSynth needs (build, tests, Blender, render checks).
# Idempotent: skips apt entirely when everything is already present.
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config git
  python3-dev python3-numpy python3-pytest pybind11-dev
  python3-distributed
  libopenimageio-dev openimageio-tools libtinyexr-dev zlib1g-dev
  libembree-dev libeigen3-dev libtbb-dev
  libgtest-dev libbenchmark-dev
  libnanoflann-dev libhnswlib-dev libfaiss-dev
  blender
  clang libclang-rt-14-dev
  xvfb xauth
  zip unzip mmdebstrap
)

missing=()
for p in "${PACKAGES[@]}"; do
  [ "$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null)" = "install ok installed" ] || missing+=("$p")
done

if [ ${#missing[@]} -gt 0 ]; then
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  echo "install_deps: installing ${missing[*]}"
  $SUDO apt-get update -q
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

# Debian's OpenImageIO CMake config lists this include dir; CMake fails if it is absent.
if [ ! -d /usr/include/opencv4 ]; then
  ${SUDO:-} mkdir -p /usr/include/opencv4 2>/dev/null || sudo mkdir -p /usr/include/opencv4
fi
