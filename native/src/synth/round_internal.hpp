// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Pieces shared by round_context.cpp and round_synth.cpp (not part of the public API).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>

#include "texsynth/synth/round_synth.hpp"

namespace texsynth {
namespace round_detail {

// Progress of one call, 0..1, for a bar the caller draws while the call runs. set() only ever
// raises the value (worker threads report out of order); reset() starts a call at 0.
class Progress {
 public:
  explicit Progress(std::atomic<float>* out) : out_(out) {}
  void reset() const {
    if (out_) out_->store(0.f, std::memory_order_relaxed);
  }
  void set(double fraction) const {
    if (!out_) return;
    const float v = float(std::clamp(fraction, 0.0, 1.0));
    float seen = out_->load(std::memory_order_relaxed);
    while (v > seen && !out_->compare_exchange_weak(seen, v, std::memory_order_relaxed)) {
    }
  }
  std::atomic<float>* raw() const { return out_; }

 private:
  std::atomic<float>* out_;
};

inline double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Bytes a synthesize_round call needs on top of the context (estimate), for `channels` and a
// sample of sample_w x sample_h pixels (before the crop).
int64_t estimate_synthesis_bytes(const RoundSynthesisContext& ctx, int64_t sample_w, int64_t sample_h, int channels);

}  // namespace round_detail
}  // namespace texsynth
