#!/usr/bin/env bash
# Everything CI runs, on Blender 3.4 (this Debian 12 host), 4.3 (Debian 13) and 5.2 LTS (Debian sid):
#   host: install Debian packages, build, C++ tests (ctest), sanitizers + fuzz replay, Python + Blender tests
#         (pytest under Blender's interpreter, /usr/bin/python3.11);
#   trixie, sid (scripts/blender_envs.sh, made while the host stages run): build against that
#         distribution's libraries and Python, ctest, all of python_tests;
#   packages: one per Blender family (scripts/package_addon.sh), each installed in a runtime environment
#         holding only Debian's blender and python3-numpy packages, then a headless Synthesize, a field-brush
#         stroke and a render;
#   blender.org packages: the self-contained cp311/cp313 extensions (built on Debian 11, package_addon.sh
#         blender-org) run every method's native calls in root filesystems holding only python3 and
#         python3-numpy, bit for bit against the Debian-built modules; then installed in Debian's Blender 3.4
#         (by hand) and 4.3 (extension install-file) beside Blender's own TBB and Embree.
# Prints the wall time of every stage at the end (also in out/test_stage_times.txt).
# TEXSYNTH_TEST_HOST_ONLY=1 runs the host stages only.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"
mkdir -p out
times="$root/out/test_stage_times.txt"
: >"$times"
stage_start=0
begin() { echo "== $1"; stage_name="$1"; stage_start=$SECONDS; }
end() { printf '%-58s %5d s\n' "$stage_name" "$((SECONDS - stage_start))" >>"$times"; }
trap 'status=$?; echo; [ "$status" = 0 ] && echo "== stage times" || echo "== stage times (up to the failure)"; cat "$times"' EXIT
all_envs=1
[ "${TEXSYNTH_TEST_HOST_ONLY:-0}" = 1 ] && all_envs=0

begin "Debian packages (host)"; bash scripts/install_deps.sh; end

envs_pid=""
if [ "$all_envs" = 1 ]; then
  # Root filesystems for Blender 4.3 and 5.2 (+ runtime-only ones) are mostly download and unpack:
  # made in the background while the host builds and tests.
  bash scripts/blender_envs.sh create trixie sid bookworm-runtime bullseye-build bookworm-python trixie-python \
    >out/blender_envs_create.log 2>&1 &
  envs_pid=$!
fi

begin "build (host, Blender 3.4)"; bash scripts/build.sh; end
begin "C++ tests (ctest, host)"; ctest --test-dir build --output-on-failure -j"$(nproc)"; end
begin "Sanitizer tests (ASan+UBSan: core, cpp_tests, fuzz replay)"; bash scripts/sanitize.sh; end
# No fuzzing stage: what a fuzzer finds depends on the day, so it is exploration (scripts/fuzz.sh, run
# before every resolve); the gate replays its kept corpora and regression inputs in the sanitizer stage.
begin "Python and Blender tests (pytest, Blender 3.4)"
PYTHONPATH="$root/addon" /usr/bin/python3.11 -m pytest -q python_tests
end

[ "$all_envs" = 1 ] || exit 0

begin "environments (Debian 13, sid, runtime-only; waited for)"
wait "$envs_pid" || { cat out/blender_envs_create.log; exit 1; }
cat out/blender_envs_create.log
end
for env in trixie sid; do
  begin "$env: build, ctest, Blender-side suites"; bash scripts/blender_envs.sh test "$env"; end
done
begin "packages (3.x zip, 4.2+ extensions)"; bash scripts/package_addon.sh host trixie sid; end
# Installs each package in the runtime-only environment named beside its tag: install_in_runtimes GLOB ENV:TAG...
install_in_runtimes() {
  local glob="$1" pair env package; shift
  for pair in "$@"; do
    env="${pair%%:*}"
    package="$(ls dist/texsynth-*-"${glob}${pair#*:}".zip)"
    echo "-- $env: $(basename "$package")"
    bash scripts/blender_envs.sh install-check "$env" "$package"
  done
}
begin "install checks (runtime-only environments)"
install_in_runtimes "" bookworm-runtime:py311 trixie-runtime:py313 sid-runtime:py314
end
begin "blender.org packages: build (Debian 11), foreign runtime, Blender 3.4 and 4.3"
bash scripts/package_addon.sh blender-org
# What the Debian-built modules compute, for the bit-for-bit comparison.
PYTHONPATH="$root/addon" /usr/bin/python3.11 python_tests/install/native_calls.py run out/native_calls-debian-cp311.npz >/dev/null
bash scripts/blender_envs.sh run trixie env PYTHONPATH=/src/addon python3 /src/python_tests/install/native_calls.py \
  run /src/out/native_calls-debian-cp313.npz >/dev/null
for pair in bookworm-python:cp311 trixie-python:cp313; do
  env="${pair%%:*}" tag="${pair#*:}"
  package="$(ls dist/texsynth-*-linux_x64-"$tag".zip)"
  echo "-- $env: $(basename "$package")"
  bash scripts/blender_envs.sh foreign-check "$env" "$package" "out/native_calls-foreign-$tag.npz"
  # Bit for bit, except where Embree's SSE2-only kernels round a ray hit one ulp from Debian's AVX2 build.
  /usr/bin/python3.11 python_tests/install/native_calls.py compare "out/native_calls-debian-$tag.npz" \
    "out/native_calls-foreign-$tag.npz" --tolerance raycast.barycentrics=1e-6 --tolerance raycast.distance=1e-6 \
    | grep -v " equal$"
done
install_in_runtimes "linux_x64-" bookworm-runtime:cp311 trixie-runtime:cp313
end
