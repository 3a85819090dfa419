#!/usr/bin/env bash
# Everything CI runs: installs Debian packages, builds, runs the C++ tests (ctest), then the
# Python and Blender tests (pytest under Blender's interpreter, /usr/bin/python3.11).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"
bash scripts/install_deps.sh
bash scripts/build.sh
echo "== C++ tests (ctest)"
ctest --test-dir build --output-on-failure -j"$(nproc)"
echo "== Sanitizer tests (ASan+UBSan build in build-asan: core, cpp_tests, fuzz seed/regression replay)"
bash scripts/sanitize.sh
echo "== Fuzzing (libFuzzer, ${TEXSYNTH_FUZZ_SECONDS:-20} s per target)"
bash scripts/fuzz.sh "${TEXSYNTH_FUZZ_SECONDS:-20}"
echo "== Python and Blender tests (pytest)"
PYTHONPATH="$root/addon" /usr/bin/python3.11 -m pytest -q python_tests
