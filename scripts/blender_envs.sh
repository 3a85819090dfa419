#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# Newer Blenders on this Debian 12 machine: root filesystems made with mmdebstrap, kept in a cache
# folder outside the repository and reused while their package list is unchanged.
#
#   trixie          Debian 13: Blender 4.3, Python 3.13, Embree 4, OpenImageIO 2.5  (+ build deps)
#   sid             Debian sid: Blender 5.2 LTS, Python 3.14, OpenImageIO 3.1, Eigen 5, pybind11 3
#   <dist>-runtime  bookworm / trixie / sid with only blender (+ python3-numpy): where packages are installed
#   <dist>-python   bookworm / trixie with only python3 + python3-numpy: a foreign runtime for the
#                   self-contained blender.org packages (no Blender, Embree, TBB or OpenImageIO)
#   bullseye-build  Debian 11 (glibc 2.31, gcc 10, TBB 2020.3), no Blender: builds the self-contained
#                   modules for blender.org builds (scripts/build_blender_org.sh); Python 3.11/3.13,
#                   pybind11, Eigen and hnswlib headers are copied in (see BULLSEYE_COPIED_HEADERS)
#
# Usage:
#   scripts/blender_envs.sh create ENV...          make (or reuse) the root filesystems
#   scripts/blender_envs.sh build ENV              configure + build + ctest inside ENV (build-<ENV>/)
#   scripts/blender_envs.sh run ENV CMD [ARG...]   run a command in ENV, the repository mounted at /src
#   scripts/blender_envs.sh test ENV               build + ctest, then all of python_tests inside ENV
#   scripts/blender_envs.sh install-check ENV PKG  install PKG in a *-runtime ENV, Synthesize + render
#   scripts/blender_envs.sh foreign-check ENV PKG OUT.npz
#                                                  unpack a blender.org PKG in a *-python ENV, run the native
#                                                  calls of every method (python_tests/install/native_calls.py)
#   scripts/blender_envs.sh path ENV               print ENV's root folder
# Needs root (chroot, mounts). TEXSYNTH_ENVS_DIR overrides the cache folder.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
envs_dir="${TEXSYNTH_ENVS_DIR:-/var/cache/texsynth-envs}"

BUILD_PACKAGES=(
  blender
  build-essential cmake pkg-config
  python3-dev python3-numpy python3-pytest pybind11-dev
  libopenimageio-dev openimageio-tools libtinyexr-dev zlib1g-dev
  libembree-dev libeigen3-dev libtbb-dev libgtest-dev libhnswlib-dev
  xvfb xauth
)
# Debian's blender package does not depend on (or recommend) python3-numpy, which TexSynth needs.
RUNTIME_PACKAGES=(blender python3-numpy)
PYTHON_PACKAGES=(python3 python3-numpy)
# Debian 11 is the oldest release reachable here: building against glibc 2.31 keeps the module near
# manylinux_2_28 (docs/dev/blender_org_packages.md). xz-utils unpacks Embree's source tarball.
BULLSEYE_BUILD_PACKAGES=(
  g++ cmake make pkg-config patchelf binutils xz-utils
  libtbb-dev libtinyexr-dev zlib1g-dev
)
# Headers bullseye lacks (Python 3.11 and 3.13) or has too old (pybind11 2.6, hnswlib 0.4), copied
# from this host (Debian 12) and the trixie environment at creation: "<source> <path>", one a line.
# Eigen 3.4 as the Debian builds use: with bullseye's 3.3.9 the textons already differ in the last bits.
BULLSEYE_COPIED_HEADERS=(
  "host /usr/include/python3.11"
  "host /usr/include/x86_64-linux-gnu/python3.11"
  "host /usr/include/eigen3"
  "host /usr/share/eigen3"
  "trixie /usr/include/python3.13"
  "trixie /usr/include/x86_64-linux-gnu/python3.13"
  "trixie /usr/include/pybind11"
  "trixie /usr/lib/cmake/pybind11"
  "trixie /usr/include/hnswlib"
)

dist_of() {
  case "$1" in
    trixie|trixie-runtime) echo trixie ;;
    sid|sid-runtime) echo sid ;;
    bookworm-runtime|bookworm-python) echo bookworm ;;
    trixie-python) echo trixie ;;
    bullseye-build) echo bullseye ;;
    *) echo "blender_envs: unknown environment '$1' (trixie, sid, bullseye-build, bookworm-runtime, trixie-runtime, sid-runtime, bookworm-python, trixie-python)" >&2
       exit 2 ;;
  esac
}

packages_of() {
  case "$1" in
    *-runtime) echo "${RUNTIME_PACKAGES[*]}" ;;
    *-python) echo "${PYTHON_PACKAGES[*]}" ;;
    bullseye-build) echo "${BULLSEYE_BUILD_PACKAGES[*]}" ;;
    *) echo "${BUILD_PACKAGES[*]}" ;;
  esac
}

need_root() {
  [ "$(id -u)" -eq 0 ] || { echo "blender_envs: needs root (chroot, bind mounts)" >&2; exit 1; }
}

ensure_mmdebstrap() {
  command -v mmdebstrap >/dev/null && return
  apt-get update -q
  DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends mmdebstrap
}

# The stamp records what an environment was made with; a different list means it is remade.
stamp_text() {
  printf 'dist=%s\npackages=%s\n' "$(dist_of "$1")" "$(packages_of "$1")"
  if [ "$1" = bullseye-build ]; then printf 'copied=%s\n' "${BULLSEYE_COPIED_HEADERS[@]}"; fi
}

# Copies BULLSEYE_COPIED_HEADERS into a new bullseye root (the trixie environment is made if missing).
copy_headers() {
  local dir="$1" line from path source_root
  for line in "${BULLSEYE_COPIED_HEADERS[@]}"; do
    read -r from path <<<"$line"
    if [ "$from" = host ]; then source_root=""; else
      [ -f "$envs_dir/$from/.texsynth-env" ] || create "$from"; source_root="$envs_dir/$from"; fi
    [ -e "$source_root$path" ] || { echo "blender_envs: bullseye-build: $from has no $path" >&2; exit 1; }
    mkdir -p "$dir$(dirname "$path")"
    rm -rf "${dir:?}$path"
    cp -a "$source_root$path" "$dir$path"
  done
}

create() {
  local env="$1" dir="$envs_dir/$1"
  if [ -f "$dir/.texsynth-env" ] && [ "$(cat "$dir/.texsynth-env")" = "$(stamp_text "$env")" ]; then
    echo "blender_envs: $env: reusing $dir"
    return
  fi
  local dist start=$SECONDS
  dist="$(dist_of "$env")"
  rm -rf "$dir" "$dir.partial"
  mkdir -p "$envs_dir"
  case "$env" in
    *-runtime|*-python|bullseye-build)
      ensure_mmdebstrap
      local options=()
      # sid's reachable mirror is a snapshot whose Release file has expired (the option stays in the chroot).
      [ "$dist" = sid ] && options+=(--aptopt='Acquire::Check-Valid-Until "false"')
      echo "blender_envs: $env: creating Debian $dist with $(packages_of "$env")"
      # Two attempts: a dropped connection to the mirror should not fail a whole CI run.
      local attempt
      for attempt in 1 2; do
        rm -rf "$dir.partial"
        # In a private mount namespace: mmdebstrap mounts proc, sys and devpts inside the new root, and
        # a killed run must not leave them mounted on the host.
        unshare --mount --propagation private -- mmdebstrap --variant=apt --mode=root --skip=cleanup/apt/lists "${options[@]}" \
          --include="$(packages_of "$env" | tr ' ' ',')" "$dist" "$dir.partial" >"$envs_dir/$env.log" 2>&1 && break
        tail -30 "$envs_dir/$env.log" >&2
        echo "blender_envs: $env: mmdebstrap failed, attempt $attempt of 2 (log: $envs_dir/$env.log)" >&2
        [ "$attempt" = 2 ] && exit 1
      done
      if [ "$env" = bullseye-build ]; then copy_headers "$dir.partial"; fi
      ;;
    *)
      # A build environment is its runtime environment plus the build packages: Blender is unpacked once.
      create "$env-runtime"
      echo "blender_envs: $env: $env-runtime + $(packages_of "$env")"
      cp -a "$envs_dir/$env-runtime" "$dir.partial"
      run_dir "$dir.partial" bash -c 'for attempt in 1 2; do
          DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "$@" && exit 0
          echo "apt-get failed, attempt $attempt of 2" >&2; done; exit 1' _ \
        $(packages_of "$env") >"$envs_dir/$env.log" 2>&1 \
        || { tail -30 "$envs_dir/$env.log" >&2; echo "blender_envs: $env: apt-get failed (log: $envs_dir/$env.log)" >&2; exit 1; }
      ;;
  esac
  stamp_text "$env" >"$dir.partial/.texsynth-env"
  mv "$dir.partial" "$dir"
  echo "blender_envs: $env: ready in $((SECONDS - start)) s ($(du -sh "$dir" | cut -f1))"
}

# Runtime environments first, in parallel (mostly download and unpack), then the build environments.
create_all() {
  local env runtimes=() pids=() failed=0 bullseye=0
  for env in "$@"; do
    dist_of "$env" >/dev/null
    case "$env" in
      bullseye-build) bullseye=1 ;;
      *-runtime|*-python) runtimes+=("$env") ;;
      *) runtimes+=("$env-runtime") ;;
    esac
  done
  for env in $(printf '%s\n' "${runtimes[@]}" | sort -u); do create "$env" & pids+=($!); done
  for pid in "${pids[@]}"; do wait "$pid" || failed=1; done
  [ "$failed" = 0 ] || exit 1
  pids=()
  for env in "$@"; do case "$env" in *-runtime|*-python|bullseye-build) ;; *) create "$env" & pids+=($!) ;; esac; done
  for pid in "${pids[@]}"; do wait "$pid" || failed=1; done
  [ "$failed" = 0 ] || exit 1
  # Last: bullseye-build copies headers out of trixie, which must not be made twice at once.
  [ "$bullseye" = 0 ] || create bullseye-build
}

# Runs a command chrooted in ENV inside a private mount namespace: the bind mounts vanish with it,
# so parallel runs and interrupted runs leave nothing mounted.
run_dir() {
  local dir="$1"; shift
  mkdir -p "$dir/src" "$dir/proc" "$dir/dev" "$dir/sys" "$dir/tmp"
  unshare --mount --propagation private -- bash -euc '
    dir="$1"; src="$2"; shift 2
    mount --rbind /dev "$dir/dev"
    mount -t proc proc "$dir/proc"
    mount --rbind /sys "$dir/sys"
    mount -t tmpfs tmpfs "$dir/tmp"
    [ -n "$src" ] && mount --bind "$src" "$dir/src"
    exec chroot "$dir" /usr/bin/env -i HOME=/root PATH=/usr/local/bin:/usr/bin:/bin:/usr/sbin:/sbin \
      LANG=C.UTF-8 ${TEXSYNTH_UPDATE_REFERENCES:+TEXSYNTH_UPDATE_REFERENCES=$TEXSYNTH_UPDATE_REFERENCES} \
      "$@"' _ "$dir" "${TEXSYNTH_ENV_SRC-$root}" "$@"
}

# run_dir on a finished environment. TEXSYNTH_ENV_SRC= (empty) runs it without the repository.
run_in() {
  local env="$1"; shift
  [ -f "$envs_dir/$env/.texsynth-env" ] || { echo "blender_envs: $env does not exist (create it first)" >&2; exit 1; }
  run_dir "$envs_dir/$env" "$@"
}

build_in() {
  local env="$1"
  case "$env" in
    *-runtime) echo "blender_envs: $env is a runtime environment (no compiler)" >&2; exit 2 ;;
    bullseye-build) echo "blender_envs: bullseye-build has no Blender: scripts/build_blender_org.sh builds there" >&2; exit 2 ;;
  esac
  # The build asks the environment's Blender for its Python; cpp tests run with ctest.
  run_in "$env" bash -euc '
    cd /src
    TEXSYNTH_BUILD_DIR=/src/build-'"$env"' bash scripts/build.sh -DTEXSYNTH_BUILD_BENCHMARKS=OFF
    ctest --test-dir /src/build-'"$env"' --output-on-failure -j"$(nproc)"'
}

# All of python_tests with this distribution's Python: the Blender-side suites (add-on, CLI, fields with
# the Xvfb GUI test, hostile harnesses, reference frames, install routes) and the module's own tests,
# which meet this stack's NumPy and pybind11.
test_in() {
  local env="$1"
  build_in "$env"
  run_in "$env" bash -euc 'cd /src && python3 -m pytest -q -p no:cacheprovider -rs python_tests'
}

# Installs a package the way an artist would, in ENV (a *-runtime environment: only Debian's blender and
# python3-numpy packages, no compiler, no -dev package, no source tree), with a throwaway home, then runs a headless
# Synthesize and a render (python_tests/install/check_installed.py).
install_check() {
  local env="$1" package="$2"
  case "$env" in *-runtime) ;; *) echo "blender_envs: install-check needs a *-runtime environment" >&2; exit 2 ;; esac
  [ -f "$package" ] || { echo "blender_envs: no package $package" >&2; exit 1; }
  local drop
  drop="$(mktemp -d)"
  cp "$package" "$drop/"
  cp "$root/python_tests/install/check_installed.py" "$root/blend_samples/bricks.png" "$drop/"
  local name kind=legacy
  name="$(basename "$package")"
  # An extension has its manifest at the top; the legacy zip holds a folder texsynth/. No `unzip | grep -q`:
  # under pipefail, grep quitting early can SIGPIPE unzip and silently pick the legacy path (a CI failure).
  local listing
  listing="$(unzip -Z1 "$package")"
  if grep -qx blender_manifest.toml <<<"$listing"; then kind=extension; fi
  local status=0
  TEXSYNTH_ENV_SRC="$drop" run_in "$env" env HOME=/tmp/home bash -euc '
    mkdir -p "$HOME"
    if command -v cc >/dev/null || command -v c++ >/dev/null; then echo "install-check: a compiler is installed" >&2; exit 1; fi
    # python3-numpy depends on python3-numpy-dev (its headers) since Debian 13: not a build package.
    dev="$(dpkg-query -W -f "\${Package}\n" | grep -- "-dev$" | grep -vx python3-numpy-dev || true)"
    if [ -n "$dev" ]; then echo "install-check: -dev packages are installed: $dev" >&2; exit 1; fi
    kind="$2"
    # An extension in a Blender older than 4.2 (no extension platform): unpacked by hand into the user
    # add-ons folder as texsynth/, as an artist would (the blender.org cp311 package in Debian 12 Blender 3.4).
    if [ "$kind" = extension ]; then
      platform="$(blender -b --factory-startup --python-expr "import bpy; print(\"EXTENSIONS\", bpy.app.version >= (4, 2, 0))" \
        2>/dev/null | sed -n "s/^EXTENSIONS //p")"
      [ "$platform" = True ] || kind=by-hand
    fi
    if [ "$kind" = by-hand ]; then
      blender -b --python-exit-code 1 --python-expr "
import addon_utils, bpy, os, zipfile
target = os.path.join(bpy.utils.user_resource(\"SCRIPTS\", path=\"addons\", create=True), \"texsynth\")
zipfile.ZipFile(\"/src/$1\").extractall(target)
bpy.utils.refresh_script_paths()  # the user add-ons folder did not exist when Blender started
assert addon_utils.enable(\"texsynth\", default_set=True, handle_error=None) is not None
bpy.ops.wm.save_userpref()" >/tmp/install.log 2>&1 || { cat /tmp/install.log; exit 1; }
    elif [ "$kind" = legacy ]; then
      blender -b --python-exit-code 1 --python-expr "
import addon_utils, bpy
bpy.ops.preferences.addon_install(filepath=\"/src/$1\")
assert addon_utils.enable(\"texsynth\", default_set=True, handle_error=None) is not None
bpy.ops.wm.save_userpref()" >/tmp/install.log 2>&1 || { cat /tmp/install.log; exit 1; }
    else
      blender --command extension install-file -r user_default --enable "/src/$1" >/tmp/install.log 2>&1 \
        || { cat /tmp/install.log; exit 1; }
    fi
    blender -b --python-exit-code 1 --python /src/check_installed.py -- /src/bricks.png /tmp/check.png >/tmp/check.log 2>&1 \
      || { cat /tmp/install.log /tmp/check.log | tail -40; exit 1; }
    grep "^CHECK_INSTALLED" /tmp/check.log' _ "$name" "$kind" || status=$?
  rm -rf "$drop"
  return $status
}

# A self-contained package in a root filesystem with only python3 + numpy (issue 31): nothing it needs may
# come from the system beyond glibc. Unpacks PKG, checks the environment really lacks the libraries, imports the
# module the package carries, runs python_tests/install/native_calls.py into OUT.npz, and prints build_info()
# and the shared objects the process mapped (the bundled TBB, no system Embree/TBB/OpenImageIO).
foreign_check() {
  local env="$1" package="$2" out="$3"
  case "$env" in *-python) ;; *) echo "blender_envs: foreign-check needs a *-python environment" >&2; exit 2 ;; esac
  [ -f "$package" ] || { echo "blender_envs: no package $package" >&2; exit 1; }
  local drop status=0
  drop="$(mktemp -d)"
  mkdir "$drop/package"
  unzip -q "$package" -d "$drop/package"
  cp "$root/python_tests/install/native_calls.py" "$root/python_tests/install/foreign_probe.py" "$drop/"
  TEXSYNTH_ENV_SRC="$drop" run_in "$env" bash -euc '
    if command -v cc >/dev/null || command -v c++ >/dev/null; then echo "foreign-check: a compiler is installed" >&2; exit 1; fi
    dev="$(dpkg-query -W -f "\${Package}\n" | grep -- "-dev$" | grep -vx python3-numpy-dev || true)"
    if [ -n "$dev" ]; then echo "foreign-check: -dev packages are installed: $dev" >&2; exit 1; fi
    system="$(ldconfig -p | grep -Ei "embree|libtbb|OpenImageIO" || true)"
    if [ -n "$system" ]; then echo "foreign-check: the system has $system" >&2; exit 1; fi
    cd /tmp
    PYTHONPATH=/src/package python3 /src/native_calls.py run /src/out.npz
    PYTHONPATH=/src/package python3 /src/foreign_probe.py /src/package' || status=$?
  [ "$status" = 0 ] && cp "$drop/out.npz" "$out"
  rm -rf "$drop"
  return $status
}

command="${1:-}"
[ $# -gt 0 ] && shift
case "$command" in
  create) need_root; [ $# -gt 0 ] || set -- trixie sid; create_all "$@" ;;
  build) need_root; build_in "$1" ;;
  run) need_root; env="$1"; shift; run_in "$env" "$@" ;;
  test) need_root; test_in "$1" ;;
  install-check) need_root; install_check "$1" "$2" ;;
  foreign-check) need_root; foreign_check "$1" "$2" "$3" ;;
  path) dist_of "$1" >/dev/null; echo "$envs_dir/$1" ;;
  *) sed -n '3,25p' "$0" >&2; exit 2 ;;
esac
