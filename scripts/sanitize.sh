#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# AddressSanitizer + UndefinedBehaviorSanitizer build (clang) of the native core, cpp_tests and the
# libFuzzer targets in build-asan/ (no Python module, no benchmarks), then runs ctest there.
# Usage: scripts/sanitize.sh [--build-only]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${TEXSYNTH_ASAN_BUILD_DIR:-$root/build-asan}"
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER=clang++ \
  -DTEXSYNTH_SANITIZE=ON -DTEXSYNTH_BUILD_FUZZERS=ON -DTEXSYNTH_BUILD_PYTHON=OFF \
  -DTEXSYNTH_BUILD_BENCHMARKS=OFF >/dev/null
cmake --build "$build" -j"$(nproc)"
[ "${1:-}" = "--build-only" ] && exit 0
# fast_unwind_on_malloc=0: see fuzz.sh (suppressions must see OpenImageIO frames).
export ASAN_OPTIONS="detect_leaks=1:fast_unwind_on_malloc=0:strict_string_checks=1:detect_stack_use_after_return=1"
export LSAN_OPTIONS="suppressions=$root/cpp_tests/sanitizers/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
ctest --test-dir "$build" --output-on-failure -j"$(nproc)"
