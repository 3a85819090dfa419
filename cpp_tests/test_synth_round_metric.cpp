// SPDX-License-Identifier: GPL-3.0-or-later
// The adaptive metric's decision (round_metric.hpp) on planted per-ring SSDs D_m: the size at which one
// candidate stands out is found by the cuts, and a fixed size picks another candidate.
#include <gtest/gtest.h>

#include <array>
#include <vector>

#include "texsynth/synth/round_metric.hpp"

namespace {

using texsynth::AdaptiveChoice;
using texsynth::AdaptiveScratch;
using texsynth::choose_by_adaptive_metric;

constexpr int kRings = 4;
using Rows = std::vector<std::array<float, kRings>>;

AdaptiveChoice decide(const Rows& rows, int min_top_size = 1, int fixed_top_size = 0, int last_ring = kRings,
                      std::array<bool, kRings + 1> coloured = {false, true, true, true, true}) {
  std::vector<float> flat;
  for (const auto& row : rows) flat.insert(flat.end(), row.begin(), row.end());
  AdaptiveScratch scratch;
  return choose_by_adaptive_metric(flat.data(), int(rows.size()), kRings, last_ring, coloured.data(), min_top_size,
                                   fixed_top_size, scratch);
}

// Candidate 0 continues the structure: close on rings 1-2, far beyond (the texture changes there).
// 1 matches the centre ring by coincidence only; 2 matches the outer rings but not the centre; 3 and 4 are poor.
const Rows kPlanted = {
    {1.0f, 2.0f, 20.0f, 20.0f},
    {0.5f, 30.0f, 30.0f, 30.0f},
    {6.0f, 6.0f, 0.0f, 0.0f},
    {10.0f, 10.0f, 10.0f, 10.0f},
    {12.0f, 12.0f, 12.0f, 12.0f},
};

}  // namespace

TEST(RoundAdaptiveMetric, CutsFindTheSizeWhereThePlantedCandidateStandsOut) {
  // Ring 1: mean 5.9, sigma 4.63, so candidates 0 and 1 survive (<= 1.27); ring 2: SSD_2 = 3 and 30.5, mean
  // 16.75, sigma 13.75, so only candidate 0 survives: T = 2, and the weighted sum 2 D_1 + D_2 is lowest for 0.
  const AdaptiveChoice adaptive = decide(kPlanted);
  EXPECT_EQ(adaptive.top_size, 2);
  EXPECT_EQ(adaptive.winner, 0);
}

TEST(RoundAdaptiveMetric, AFixedSizePicksAnotherCandidate) {
  const AdaptiveChoice one = decide(kPlanted, 1, 1);
  EXPECT_EQ(one.top_size, 1);
  EXPECT_EQ(one.winner, 1);  // the coincidental centre match
  const AdaptiveChoice four = decide(kPlanted, 1, 4);
  EXPECT_EQ(four.top_size, 4);
  EXPECT_EQ(four.winner, 2);  // 4 D_1 + 3 D_2 + 2 D_3 + D_4: 42 against the planted 70
}

TEST(RoundAdaptiveMetric, MinTopSizeDelaysTheFirstCut) {
  // Starting at size 2: SSD_2 = 3, 30.5, 12, 20, 24 (mean 17.9, sigma 9.5): only candidate 0 is <= 8.4.
  const AdaptiveChoice choice = decide(kPlanted, 2);
  EXPECT_EQ(choice.top_size, 2);
  EXPECT_EQ(choice.winner, 0);
}

TEST(RoundAdaptiveMetric, FixedSizeIsCappedAtTheLastColouredRing) {
  const AdaptiveChoice choice = decide(kPlanted, 1, 4, 2, {false, true, true, false, false});
  EXPECT_EQ(choice.top_size, 2);
  EXPECT_EQ(choice.winner, 0);
}

TEST(RoundAdaptiveMetric, EqualCandidatesAreNotCutAndTheFirstWins) {
  const Rows flat(5, {3.0f, 3.0f, 3.0f, 3.0f});
  const AdaptiveChoice choice = decide(flat);
  EXPECT_EQ(choice.top_size, kRings);  // sigma = 0 at every size: no cut, T = the last ring
  EXPECT_EQ(choice.winner, 0);
}

TEST(RoundAdaptiveMetric, AnUncolouredRingMakesNoCut) {
  // Ring 1 uncoloured: its terms are zero for all, and the cut waits for ring 2 (then only candidate 2 is low).
  const Rows rows = {{0, 9.0f, 9.0f, 9.0f}, {0, 8.0f, 8.0f, 8.0f}, {0, 1.0f, 1.0f, 1.0f}, {0, 9.5f, 9.5f, 9.5f}};
  const AdaptiveChoice choice = decide(rows, 1, 0, kRings, {false, false, true, true, true});
  EXPECT_EQ(choice.top_size, 2);
  EXPECT_EQ(choice.winner, 2);
}

TEST(RoundAdaptiveMetric, WhenNoneIsBelowMeanMinusSigmaTheMinimumIsKept) {
  // Two candidates: sigma = half the gap, mean - sigma = the smaller one, so the cut keeps exactly it.
  // Tied minima among three ({1, 0, 0}): mean - sigma < 0, none is below, and the first minimum alone is kept.
  const AdaptiveChoice two = decide({{4.0f, 4.0f, 4.0f, 4.0f}, {2.0f, 2.0f, 2.0f, 2.0f}});
  EXPECT_EQ(two.top_size, 1);
  EXPECT_EQ(two.winner, 1);
  const AdaptiveChoice tied = decide({{1.0f, 1.0f, 1.0f, 1.0f}, {0, 0, 0, 0}, {0, 0, 0, 0}});
  EXPECT_EQ(tied.top_size, 1);
  EXPECT_EQ(tied.winner, 1);
}
