// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Threads a pass may use: the task arena's concurrency, capped by any tbb::global_control limit
// (tests and callers pin 1 thread that way).
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <algorithm>

namespace texsynth {

inline int usable_threads() {
  return int(std::min<size_t>(size_t(tbb::this_task_arena::max_concurrency()),
                              tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)));
}

}  // namespace texsynth
