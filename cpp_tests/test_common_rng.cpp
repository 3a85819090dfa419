// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>

#include <vector>

#include "texsynth/common/rng.hpp"

using texsynth::Rng;

TEST(Rng, SameSeedSameSequence) {
  Rng a(42, 7), b(42, 7);
  for (int i = 0; i < 1000; ++i) ASSERT_EQ(a.next_u32(), b.next_u32());
}

TEST(Rng, DifferentStreamsDiffer) {
  Rng a(42, 1), b(42, 2);
  int equal = 0;
  for (int i = 0; i < 1000; ++i) equal += a.next_u32() == b.next_u32();
  EXPECT_LT(equal, 5);
}

TEST(Rng, UniformAndBelowStayInRangeAndCoverIt) {
  Rng r(1);
  std::vector<int> hist(10, 0);
  for (int i = 0; i < 100000; ++i) {
    double u = r.uniform();
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
    uint32_t b = r.below(10);
    ASSERT_LT(b, 10u);
    hist[b]++;
  }
  for (int h : hist) EXPECT_NEAR(h, 10000, 600);
}
