// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The adaptive metric's decision for one point of round-neighbourhood synthesis (Chen & Dong §5.2.2;
// docs/algorithms/round_neighbourhoods.md, "Metric"), apart from the colour reads so it can be tested on its own.
#include <vector>

namespace texsynth {

struct AdaptiveChoice {
  int winner = 0;    // index of the chosen candidate
  int top_size = 0;  // the neighbourhood size T (rings) the choice was made at
};

// Reused between calls so a point allocates nothing.
struct AdaptiveScratch {
  std::vector<int> alive, next_alive;
  std::vector<double> metric;
};

// ring_ssd: `candidates` rows of `rings` values, D_m = the candidate's squared colour differences summed over
// ring m (outliers already clamped). ring_coloured[m], m = 0..last_ring: ring m has a coloured template point.
// last_ring >= 1 and candidates >= 1.
// Top size: from all candidates, at s = min_top_size, ..., keep those whose SSD_s = sum_{m<=s} D_m is at most
// mean - sigma of the survivors (the minimum alone when none is; no cut when sigma is ~0 or ring s is
// uncoloured) until one is left; T = that s, or last_ring. fixed_top_size > 0 skips the cuts: T =
// min(last_ring, fixed_top_size). Winner: argmin over ALL candidates of sum_{s<=T} SSD_s, i.e. ring m weighted
// T - m + 1; ties go to the lowest index.
AdaptiveChoice choose_by_adaptive_metric(const float* ring_ssd, int candidates, int rings, int last_ring,
                                         const bool* ring_coloured, int min_top_size, int fixed_top_size,
                                         AdaptiveScratch& scratch);

}  // namespace texsynth
