// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/synth/round_metric.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>

namespace texsynth {
namespace {
// The cut is skipped when the SSD spread is this small relative to its mean (flat regions).
constexpr double kFlatSpread = 1e-6;
}  // namespace

AdaptiveChoice choose_by_adaptive_metric(const float* ring_ssd, int candidates, int rings, int last_ring,
                                         const bool* ring_coloured, int min_top_size, int fixed_top_size,
                                         AdaptiveScratch& s) {
  const int n = candidates, K = rings;
  s.alive.resize(size_t(n));
  for (int c = 0; c < n; ++c) s.alive[size_t(c)] = c;
  s.metric.assign(size_t(n), 0.0);  // SSD_s of the alive candidates
  int top = last_ring;
  if (fixed_top_size > 0) top = std::min(last_ring, fixed_top_size);
  for (int sz = 1; sz <= last_ring && fixed_top_size == 0; ++sz) {
    for (int c : s.alive) s.metric[size_t(c)] += ring_ssd[size_t(c) * K + sz - 1];
    if (sz < min_top_size && sz < last_ring) continue;
    if (ring_coloured[sz]) {
      double mean = 0, sq = 0;
      for (int c : s.alive) mean += s.metric[size_t(c)];
      mean /= double(s.alive.size());
      for (int c : s.alive) sq += (s.metric[size_t(c)] - mean) * (s.metric[size_t(c)] - mean);
      const double sigma = std::sqrt(sq / double(s.alive.size()));
      if (sigma > kFlatSpread * mean && sigma > 0) {
        s.next_alive.clear();
        for (int c : s.alive)
          if (s.metric[size_t(c)] <= mean - sigma) s.next_alive.push_back(c);
        if (s.next_alive.empty()) {
          int m = s.alive[0];
          for (int c : s.alive)
            if (s.metric[size_t(c)] < s.metric[size_t(m)]) m = c;
          s.next_alive.push_back(m);
        }
        s.alive.swap(s.next_alive);
      }
    }
    if (s.alive.size() == 1) {
      top = sz;
      break;
    }
  }
  // sum_{s<=T} SSD_s = sum_m (T - m + 1) D_m over all candidates.
  AdaptiveChoice choice;
  choice.top_size = top;
  double best_v = std::numeric_limits<double>::infinity();
  for (int c = 0; c < n; ++c) {
    const float* rs = &ring_ssd[size_t(c) * K];
    double v = 0;
    for (int m = 1; m <= top; ++m) v += double(top - m + 1) * rs[m - 1];
    if (v < best_v) best_v = v, choice.winner = c;
  }
  return choice;
}

}  // namespace texsynth
