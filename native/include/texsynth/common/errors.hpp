// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Error convention for the whole core:
//  - std::invalid_argument : the caller's input is wrong (bad shape, range, NaN, corrupt file).
//                            The Python layer turns it into ValueError.
//  - texsynth::CacheError  : a cache file is stale/truncated/corrupt; callers recompute.
//  - std::runtime_error    : anything else the caller cannot fix (I/O failure, out of memory).
// Core code never aborts and never leaves outputs half-written: it validates, then computes
// into fresh buffers, then returns them.
#include <atomic>
#include <stdexcept>
#include <string>

namespace texsynth {

class CacheError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Thrown by long computations when the caller's cancel flag is raised.
class Cancelled : public std::runtime_error {
 public:
  Cancelled() : std::runtime_error("cancelled") {}
};

// Long computations take an optional flag another thread raises to stop them; they call this often
// enough that a raised flag is noticed within a small fraction of a second.
inline void throw_if_cancelled(const std::atomic<bool>* cancel) {
  if (cancel && cancel->load(std::memory_order_relaxed)) throw Cancelled();
}

}  // namespace texsynth
