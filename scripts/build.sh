#!/usr/bin/env bash
# Configures and builds TexSynth (Release) into build/, placing texsynth_native in addon/.
# Usage: scripts/build.sh [extra cmake -D options]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build_dir="${TEXSYNTH_BUILD_DIR:-$root/build}"
mkdir -p "$build_dir"
# Quiet configure, but say which stack was found (Python, Embree, OpenImageIO, Eigen).
if ! cmake -S "$root" -B "$build_dir" -DCMAKE_BUILD_TYPE=Release "$@" >"$build_dir/configure.log" 2>&1; then
  cat "$build_dir/configure.log" >&2
  exit 1
fi
grep "^-- TexSynth:" "$build_dir/configure.log" || true
cmake --build "$build_dir" -j"$(nproc)"
