#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# Self-contained texsynth_native modules for blender.org builds (Linux x86-64), one per Python ABI,
# built in scripts/blender_envs.sh's bullseye-build environment (glibc 2.31, gcc 10, TBB 2020.3):
#   1. Embree from Debian's source tarball (SHA-256 checked against the signed Sources index), static,
#      SSE2, triangles only: cached under the environments folder by version and options.
#   2. The module (TEXSYNTH_SELF_CONTAINED=ON, TEXSYNTH_IMAGE_FILES=OFF): libstdc++/libgcc static.
#   3. TBB bundled the way auditwheel does: texsynth_native.libs/libtbb-<sha256[:8]>.so.2, RPATH $ORIGIN.
#   4. The floor check, which fails the build: no GLIBC_ version above 2.28, no C++ runtime reference
#      from the module, NEEDED only the manylinux_2_28 system set and the bundled files.
# Usage: scripts/build_blender_org.sh [cp311] [cp313]        (default: both)
# Output: build-blender-org/<abi>/out/ (the module and texsynth_native.libs/), build-blender-org/<abi>/report.txt.
# Design and measurements: docs/dev/blender_org_packages.md. Needs root (the environment is a chroot).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
envs_dir="${TEXSYNTH_ENVS_DIR:-/var/cache/texsynth-envs}"
envs="$root/scripts/blender_envs.sh"

# Embree: Debian 12's source package. Debian 13's 4.3.3 is what the code prefers, but its tarball is not
# reachable from the build machines (404 on the mirror); 3.13.5 is, and is what Debian 12's build links.
EMBREE_VERSION=3.13.5
EMBREE_DEBIAN_SUITE=bookworm
EMBREE_TARBALL="embree_${EMBREE_VERSION}+dfsg.orig.tar.xz"
MIRROR=http://deb.debian.org/debian
# Only what TexSynth calls: one closest-hit ray at a time (rtcIntersect1) against triangle meshes, no
# filter callbacks, no masks. SSE2 alone also makes hits identical on every x86-64 CPU.
EMBREE_OPTIONS=(
  -DCMAKE_BUILD_TYPE=Release -DCMAKE_POSITION_INDEPENDENT_CODE=ON
  -DEMBREE_STATIC_LIB=ON -DEMBREE_ISPC_SUPPORT=OFF -DEMBREE_TUTORIALS=OFF -DEMBREE_TASKING_SYSTEM=INTERNAL
  -DEMBREE_MAX_ISA=NONE -DEMBREE_ISA_SSE2=ON -DEMBREE_ISA_SSE42=OFF -DEMBREE_ISA_AVX=OFF -DEMBREE_ISA_AVX2=OFF
  -DEMBREE_ISA_AVX512=OFF -DEMBREE_ISA_AVX512SKX=OFF
  -DEMBREE_GEOMETRY_TRIANGLE=ON -DEMBREE_GEOMETRY_QUAD=OFF -DEMBREE_GEOMETRY_CURVE=OFF
  -DEMBREE_GEOMETRY_SUBDIVISION=OFF -DEMBREE_GEOMETRY_USER=OFF -DEMBREE_GEOMETRY_INSTANCE=OFF
  -DEMBREE_GEOMETRY_GRID=OFF -DEMBREE_GEOMETRY_POINT=OFF
  -DEMBREE_RAY_PACKETS=OFF -DEMBREE_RAY_MASK=OFF -DEMBREE_FILTER_FUNCTION=OFF -DEMBREE_BACKFACE_CULLING=OFF
  -DEMBREE_STAT_COUNTERS=OFF
)
FLOOR_HEADER=native/compat/glibc_2_28_floor.h

# Python ABIs: EXT_SUFFIX and header folder inside the environment (copied in by blender_envs.sh).
abi_suffix() { echo ".cpython-3${1#cp3}-x86_64-linux-gnu.so"; }
abi_headers() { echo "/usr/include/python3.${1#cp3}"; }

# ---------------------------------------------------------------------------------------------------
# Inside the environment (this script runs itself there with --inside-*; the repository is /src).

# The manylinux_2_28 system set. The bundled TBB also needs the C++ runtime, which every manylinux_2_28
# system has (AlmaLinux 8, gcc 8): its symbol versions are capped at what gcc 8's libstdc++ provides.
SYSTEM_LIBS="libc.so.6 libm.so.6 libpthread.so.0 libdl.so.2 librt.so.1 ld-linux-x86-64.so.2"
CXX_RUNTIME_LIBS="libstdc++.so.6 libgcc_s.so.1"
GLIBC_FLOOR=2.28
GLIBCXX_CAP=3.4.25 CXXABI_CAP=1.3.11 GCC_CAP=8.0.0

inside_embree() {
  local jobs="$1" start=$SECONDS
  shift
  cd /src
  tar xJf "$EMBREE_TARBALL"
  cmake -S "embree-$EMBREE_VERSION" -B build -DCMAKE_INSTALL_PREFIX=/src/install \
    -DCMAKE_CXX_FLAGS="-include /src/glibc_2_28_floor.h" -DCMAKE_C_FLAGS="-include /src/glibc_2_28_floor.h" \
    "$@" >configure.log 2>&1 || { tail -40 configure.log; exit 1; }
  cmake --build build -j"$jobs" >build.log 2>&1 || { tail -60 build.log; exit 1; }
  # Debian's +dfsg tarball drops the prebuilt readme.pdf, which Embree's install step copies.
  : >"embree-$EMBREE_VERSION/readme.pdf"
  cmake --install build >install.log 2>&1 || { tail -20 install.log; exit 1; }
  rm -rf install/share
  echo "build_seconds=$((SECONDS - start))" >install/build-time.txt
}

# Highest version of one kind (GLIBC, GLIBCXX, CXXABI, GCC) that FILE's undefined symbols need.
needs_max() { objdump -T "$1" | awk '/\*UND\*/' | { grep -oE "\\b$2_[0-9][0-9.]*" || true; } | sed "s/^$2_//" | sort -V | tail -1; }
above() { [ -n "$1" ] && [ "$1" != "$2" ] && [ "$(printf '%s\n%s\n' "$1" "$2" | sort -V | tail -1)" = "$1" ]; }

inside_bundle_and_check() {
  local abi="$1" linked="$2" out="$3" report="$4"
  local module="$out/texsynth_native$(abi_suffix "$abi")" libs="$out/texsynth_native.libs"
  # A fresh copy of the linked module each time: patchelf on an already patched file grows it.
  rm -rf "$out"
  mkdir -p "$libs"
  cp "$linked/texsynth_native$(abi_suffix "$abi")" "$module"
  # auditwheel's repair: copy, rename with a content hash (two add-ons' TBBs never share a file name),
  # point the module's NEEDED at the new name, and find it through RPATH.
  local tbb=/usr/lib/x86_64-linux-gnu/libtbb.so.2 hash name
  hash="$(sha256sum "$tbb" | cut -c1-8)"
  name="libtbb-$hash.so.2"
  cp "$tbb" "$libs/$name"
  patchelf --set-soname "$name" "$libs/$name"
  patchelf --replace-needed libtbb.so.2 "$name" "$module"
  patchelf --remove-rpath "$module"
  patchelf --force-rpath --set-rpath '$ORIGIN/texsynth_native.libs' "$module"

  local failed=0 file needed lib highest=0 v
  {
    echo "abi=$abi"
    for file in "$module" "$libs"/*; do
      needed="$(readelf -d "$file" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p' | tr '\n' ' ')"
      v="$(needs_max "$file" GLIBC)"
      echo "$(basename "$file"): $(stat -c %s "$file") bytes, GLIBC_$v, NEEDED: $needed"
      above "$v" "$GLIBC_FLOOR" && { echo "FAIL: $(basename "$file") needs GLIBC_$v (floor $GLIBC_FLOOR)"; failed=1; }
      above "$v" "$highest" && highest="$v"
      for lib in $needed; do
        case " $SYSTEM_LIBS $(cd "$libs" && ls | tr '\n' ' ') " in *" $lib "*) continue ;; esac
        if [ "$file" != "$module" ] && [[ " $CXX_RUNTIME_LIBS " == *" $lib "* ]]; then continue; fi
        echo "FAIL: $(basename "$file") needs $lib, neither a manylinux_2_28 system library nor bundled"
        failed=1
      done
      if [ "$file" = "$module" ]; then
        # libstdc++ and libgcc are static: no reference to their versions may remain.
        for kind in GLIBCXX CXXABI GCC; do
          v="$(needs_max "$file" $kind)"
          [ -z "$v" ] || { echo "FAIL: the module needs ${kind}_$v (libstdc++/libgcc should be static)"; failed=1; }
        done
        # The version script: the module exports its init function only.
        local exported
        exported="$(objdump -T "$file" | awk '/^[0-9a-f]+ / && !/\*UND\*/ {print $NF}' | grep -vx "PyInit_texsynth_native" || true)"
        [ -z "$exported" ] || { echo "FAIL: the module exports more than PyInit_texsynth_native: $(echo $exported | head -c 300)"; failed=1; }
      else
        local kind cap_var
        for kind in GLIBCXX CXXABI GCC; do
          v="$(needs_max "$file" $kind)"
          cap_var="${kind}_CAP"
          above "$v" "${!cap_var}" && { echo "FAIL: $(basename "$file") needs ${kind}_$v (manylinux_2_28 has ${!cap_var})"; failed=1; }
          [ -z "$v" ] || echo "  C++ runtime: ${kind}_$v (manylinux_2_28 cap ${!cap_var})"
        done
      fi
    done
    echo "highest GLIBC version needed: GLIBC_$highest (floor $GLIBC_FLOOR)"
    echo "RPATH: $(patchelf --print-rpath "$module")"
  } | tee "$report"
  ! grep -q '^FAIL' "$report"
}

case "${1:-}" in
  --inside-embree) shift; inside_embree "$@"; exit ;;
  --inside-bundle) shift; inside_bundle_and_check "$@"; exit ;;
esac

# ---------------------------------------------------------------------------------------------------
# On the host.
abis=("$@")
[ ${#abis[@]} -gt 0 ] || abis=(cp311 cp313)
for abi in "${abis[@]}"; do
  case "$abi" in cp311|cp313) ;; *) echo "build_blender_org: unknown ABI '$abi' (cp311, cp313)" >&2; exit 2 ;; esac
done
jobs="${TEXSYNTH_JOBS:-2}"
bash "$envs" create bullseye-build

# Embree's tarball, checked link by link: InRelease (signed by Debian's archive keys) -> Sources.xz -> tarball.
downloads="$envs_dir/downloads"
mkdir -p "$downloads"
fetch_verified_embree() {
  local tarball="$downloads/$EMBREE_TARBALL" tmp
  [ -f "$tarball.verified" ] && return
  tmp="$(mktemp -d)"
  curl -fsS -o "$tmp/InRelease" "$MIRROR/dists/$EMBREE_DEBIAN_SUITE/InRelease"
  gpgv --keyring /usr/share/keyrings/debian-archive-keyring.gpg "$tmp/InRelease" 2>/dev/null \
    || { echo "build_blender_org: $EMBREE_DEBIAN_SUITE's InRelease has no valid Debian signature" >&2; exit 1; }
  curl -fsS -o "$tmp/Sources.xz" "$MIRROR/dists/$EMBREE_DEBIAN_SUITE/main/source/Sources.xz"
  local sources_sha
  sources_sha="$(awk '/^SHA256:/{s=1; next} /^[A-Za-z]/{s=0} s && $3 == "main/source/Sources.xz" {print $1}' "$tmp/InRelease")"
  [ "$(sha256sum "$tmp/Sources.xz" | cut -d' ' -f1)" = "$sources_sha" ] \
    || { echo "build_blender_org: Sources.xz does not match InRelease" >&2; exit 1; }
  local want
  # awk reads to the end: quitting early would kill xz with SIGPIPE, a failure under pipefail.
  want="$(xz -dc "$tmp/Sources.xz" | awk -v f="$EMBREE_TARBALL" '/^Package: /{p=($2=="embree")} p && /^Checksums-Sha256:/{c=1; next} /^[A-Za-z]/{c=0} p && c && $3 == f && !n++ {print $1}')"
  [ -n "$want" ] || { echo "build_blender_org: $EMBREE_DEBIAN_SUITE's Sources lists no $EMBREE_TARBALL" >&2; exit 1; }
  if [ ! -f "$tarball" ]; then
    curl -fsS -o "$tarball.part" "$MIRROR/pool/main/e/embree/$EMBREE_TARBALL"
    mv "$tarball.part" "$tarball"
  fi
  local got
  got="$(sha256sum "$tarball" | cut -d' ' -f1)"
  [ "$got" = "$want" ] || { rm -f "$tarball"; echo "build_blender_org: $EMBREE_TARBALL: SHA-256 $got, Sources says $want" >&2; exit 1; }
  echo "$want" >"$tarball.verified"
  rm -rf "$tmp"
  echo "build_blender_org: $EMBREE_TARBALL verified (SHA-256 $want, $EMBREE_DEBIAN_SUITE Sources, signed InRelease)"
}

# The cache key covers everything that changes the built library.
embree_key="$EMBREE_VERSION-$( { printf '%s\n' "${EMBREE_OPTIONS[@]}"; cat "$root/$FLOOR_HEADER"; \
  cat "$envs_dir/bullseye-build/.texsynth-env"; } | sha256sum | cut -c1-12)"
embree_cache="$envs_dir/embree-static/$embree_key"
if [ ! -f "$embree_cache/build-time.txt" ]; then
  fetch_verified_embree
  work="$envs_dir/embree-static/work-$embree_key"
  rm -rf "$work"
  mkdir -p "$work"
  cp "$downloads/$EMBREE_TARBALL" "$root/$FLOOR_HEADER" "$root/scripts/build_blender_org.sh" "$work/"
  echo "build_blender_org: building Embree $EMBREE_VERSION (static, SSE2, triangles) -> $embree_cache"
  TEXSYNTH_ENV_SRC="$work" bash "$envs" run bullseye-build bash /src/build_blender_org.sh --inside-embree "$jobs" "${EMBREE_OPTIONS[@]}"
  rm -rf "$embree_cache"
  mv "$work/install" "$embree_cache"
  rm -rf "$work"
fi
embree_size="$(du -sk "$embree_cache/lib" | cut -f1)"
echo "build_blender_org: Embree $embree_key: $(cat "$embree_cache/build-time.txt"), lib/ ${embree_size} KB"
# The module build sees it at a fixed path inside the environment.
env_embree="/opt/texsynth-embree/$embree_key"
if [ ! -d "$envs_dir/bullseye-build$env_embree" ]; then
  mkdir -p "$envs_dir/bullseye-build/opt/texsynth-embree"
  cp -a "$embree_cache" "$envs_dir/bullseye-build$env_embree"
fi

env_stamp="$(sha256sum <"$envs_dir/bullseye-build/.texsynth-env" | cut -c1-12)-$embree_key"
for abi in "${abis[@]}"; do
  build="build-blender-org/$abi"
  start=$SECONDS
  # A remade environment copies headers with their old dates: make would keep objects built against the
  # previous ones, so a build folder from another environment or Embree starts afresh.
  if [ "$(cat "$root/$build/.env-stamp" 2>/dev/null)" != "$env_stamp" ]; then
    rm -rf "${root:?}/$build"
    mkdir -p "$root/$build"
    echo "$env_stamp" >"$root/$build/.env-stamp"
  fi
  bash "$envs" run bullseye-build bash -euc '
    cd /src
    mkdir -p "$1"
    cmake -S /src -B "$1" -DCMAKE_BUILD_TYPE=Release -DTEXSYNTH_SELF_CONTAINED=ON -DTEXSYNTH_IMAGE_FILES=OFF \
      -DTEXSYNTH_BUILD_TESTS=OFF -DTEXSYNTH_BUILD_BENCHMARKS=OFF -DTEXSYNTH_MODULE_OUTPUT_DIR="/src/$1/linked" \
      -DTEXSYNTH_PYTHON_INCLUDE_DIRS="$2" -DTEXSYNTH_PYTHON_EXT_SUFFIX="$3" \
      -DCMAKE_PREFIX_PATH="$4" \
      -DZLIB_LIBRARY=/usr/lib/x86_64-linux-gnu/libz.a >"$1/configure.log" 2>&1 || { cat "$1/configure.log"; exit 1; }
    grep "^-- TexSynth:" "$1/configure.log"
    cmake --build "$1" -j"$5" >"$1/build.log" 2>&1 || { grep -B2 -A12 -m3 "error" "$1/build.log"; tail -20 "$1/build.log"; exit 1; }
    bash /src/scripts/build_blender_org.sh --inside-bundle "$6" "/src/$1/linked" "/src/$1/out" "/src/$1/report.txt"
  ' _ "$build" "$(abi_headers "$abi")" "$(abi_suffix "$abi")" "$env_embree" "$jobs" "$abi"
  echo "build_blender_org: $abi built in $((SECONDS - start)) s: $root/$build/out"
done
