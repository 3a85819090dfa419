#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# Exploratory fuzzing: builds the libFuzzer targets (clang, ASan+UBSan, build-asan/) and runs each for
# a bounded time. Run it before every resolve. It is not part of the gate (scripts/test.sh): what it
# finds depends on the day and the machine, so its result cannot pass or fail a change. The gate
# replays the committed inputs instead (scripts/sanitize.sh: ctest's fuzz_<target>_replay runs every
# file in cpp_tests/fuzz/corpus/<target>/ and cpp_tests/fuzz/regressions/<target>/ once).
# Usage: scripts/fuzz.sh [SECONDS_PER_TARGET=25] [target ...]   (default: every fuzz_* target)
# New inputs go to build-asan/fuzz-corpus/<target>/ (seeds: cpp_tests/fuzz/corpus/<target>/).
# A finding (crash-*, timeout-*, oom-* or leak-* in build-asan/fuzz-artifacts/<target>/) becomes a
# regression input: reproduce it with build-asan/cpp_tests/fuzz/<target> <file>, fix the cause, copy
# the file into cpp_tests/fuzz/regressions/<target>/ under a name that says what it does, and add a
# unit test in cpp_tests/ that asserts the clear error or result (a timeout or out-of-memory finding:
# a bound on what the input may allocate, not on wall time). Commit both; the gate then replays it.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
seconds="${1:-25}"
shift || true
build="${TEXSYNTH_ASAN_BUILD_DIR:-$root/build-asan}"
bash "$root/scripts/sanitize.sh" --build-only
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  for src in "$root"/cpp_tests/fuzz/fuzz_*.cpp; do targets+=("$(basename "$src" .cpp)"); done
fi
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1}"
export LSAN_OPTIONS="suppressions=$root/cpp_tests/sanitizers/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
status=0
for target in "${targets[@]}"; do
  corpus="$build/fuzz-corpus/$target"
  artifacts="$build/fuzz-artifacts/$target"
  mkdir -p "$corpus" "$artifacts"
  log="$build/fuzz-$target.log"
  extra=()
  # OpenImageIO's PNG reader leaks 31 bytes per truncated file (lsan.supp); matching that
  # suppression needs slow malloc unwinding (~25x fewer executions), so fuzz_image fuzzes without
  # leak checks. Leaks in TexSynth's own code are covered by the other targets and by ctest.
  # fuzz_image also refuses any single allocation above 1100 MB, as its ctest replay does
  # (cpp_tests/fuzz/CMakeLists.txt: the loader's largest legal buffer is 1024 MB).
  target_asan="$ASAN_OPTIONS"
  [ "$target" = fuzz_image ] && extra=(-detect_leaks=0 -malloc_limit_mb=1100) && target_asan="$ASAN_OPTIONS:detect_leaks=0"
  # -rss_limit_mb: a legal input must not need more; -timeout: one input taking longer is a hang.
  if ASAN_OPTIONS="$target_asan" "$build/cpp_tests/fuzz/$target" "$corpus" "$root/cpp_tests/fuzz/corpus/$target" \
      -max_total_time="$seconds" -timeout=10 -rss_limit_mb=3072 -max_len=65536 \
      -artifact_prefix="$artifacts/" -print_final_stats=1 "${extra[@]}" >"$log" 2>&1; then
    execs=$(grep -m1 'stat::number_of_executed_units' "$log" | awk '{print $2}')
    echo "fuzz: $target ok: ${execs:-?} executions in ${seconds} s, corpus $(ls "$corpus" | wc -l) inputs"
  else
    status=1
    echo "fuzz: $target FAILED (log $log):"
    grep -E 'ERROR|SUMMARY|invariant|uncaught|Test unit written' "$log" | head -20
  fi
done
exit $status
