// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "synthetic_texture.hpp"
#include "texsynth/common/rng.hpp"
#include "texsynth/preprocess/features.hpp"
#include "texsynth/preprocess/jump_map.hpp"
#include "texsynth/preprocess/preprocess.hpp"

namespace {

int chebyshev(int a, int b, int w, int h, bool periodic) {
  int dx = std::abs(a % w - b % w), dy = std::abs(a / w - b / w);
  if (periodic) {
    dx = std::min(dx, w - dx);
    dy = std::min(dy, h - dy);
  }
  return std::max(dx, dy);
}

class JumpMapOnBricks : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    image_ = new texsynth::Image(texsynth_test::brick_texture(96, 80, 2));
    result_ = new texsynth::Preprocessed(texsynth::preprocess(*image_, texsynth::PreprocessParams{}));
    // Independent yardstick: the full, unreduced neighbourhood features.
    full_ = new texsynth::Features(texsynth::compute_features(*image_, 11, 0, false, 0));
  }
  static void TearDownTestSuite() {
    delete image_;
    delete result_;
    delete full_;
  }
  static texsynth::Image* image_;
  static texsynth::Preprocessed* result_;
  static texsynth::Features* full_;
};
texsynth::Image* JumpMapOnBricks::image_ = nullptr;
texsynth::Preprocessed* JumpMapOnBricks::result_ = nullptr;
texsynth::Features* JumpMapOnBricks::full_ = nullptr;

TEST_F(JumpMapOnBricks, TargetsAreMuchCloserThanRandomPairs) {
  const auto& r = *result_;
  const int n = r.pixel_count(), k = r.jump_map.k;
  std::vector<float> jump_d, random_d;
  texsynth::Rng rng(4);
  for (int p = 0; p < n; ++p) {
    const int t = r.jump_map.targets[size_t(p) * k];
    if (t >= 0) jump_d.push_back(texsynth::squared_distance(full_->row(p), full_->row(t), full_->dims));
    random_d.push_back(texsynth::squared_distance(full_->row(p), full_->row(rng.below(n)), full_->dims));
  }
  ASSERT_GT(jump_d.size(), size_t(n) * 9 / 10);
  auto percentile = [](std::vector<float> v, double q) {
    std::nth_element(v.begin(), v.begin() + size_t(q * (v.size() - 1)), v.end());
    return v[size_t(q * (v.size() - 1))];
  };
  // Median best jump is closer than all but the closest 5% of random pairs, by a wide margin.
  EXPECT_LT(percentile(jump_d, 0.5), 0.5 * percentile(random_d, 0.05));
  EXPECT_LT(percentile(jump_d, 0.9), percentile(random_d, 0.10));
}

TEST_F(JumpMapOnBricks, SearchIsCloseToExactKnn) {
  // Compare with brute-force kNN (same reduced features) for a sample of pixels.
  const auto& r = *result_;
  const auto reduced = texsynth::compute_features(*image_, 11, 16, false, 0);
  texsynth::JumpSearchParams jp;
  double approx_sum = 0, exact_sum = 0;
  int hits = 0, total = 0;
  for (int p = 13; p < r.pixel_count(); p += 97) {
    std::vector<int32_t> targets;
    std::vector<float> distances;
    texsynth::brute_force_jumps(reduced, r.width, r.height, p, jp, targets, distances);
    for (int i = 0; i < r.jump_map.k; ++i) {
      const int t = r.jump_map.targets[size_t(p) * r.jump_map.k + i];
      if (t >= 0) approx_sum += texsynth::squared_distance(reduced.row(p), reduced.row(t), reduced.dims);
      hits += std::count(targets.begin(), targets.end(), t) > 0;
      ++total;
    }
    for (float d : distances) exact_sum += d;
  }
  EXPECT_LT(approx_sum, 1.5 * exact_sum);
  EXPECT_GT(double(hits) / total, 0.3);
}

TEST_F(JumpMapOnBricks, ExcludesOwnNeighbourhoodAndIsSorted) {
  const auto& r = *result_;
  const int k = r.jump_map.k;
  for (int p = 0; p < r.pixel_count(); ++p) {
    bool empty_seen = false;
    for (int i = 0; i < k; ++i) {
      const int t = r.jump_map.targets[size_t(p) * k + i];
      if (t < 0) {
        empty_seen = true;
        continue;
      }
      ASSERT_FALSE(empty_seen) << "empty slot before a jump at pixel " << p;
      ASSERT_LT(t, r.pixel_count());
      ASSERT_GT(chebyshev(p, t, r.width, r.height, false), 5) << p << " -> " << t;
      // Sorted best first: weights never increase along the list.
      if (i > 0) ASSERT_LE(r.jump_map.weights[size_t(p) * k + i], r.jump_map.weights[size_t(p) * k + i - 1]);
    }
  }
}

TEST_F(JumpMapOnBricks, WeightsSumToAtMostOneAndPoorMatchesGetLess) {
  const auto& r = *result_;
  const int k = r.jump_map.k;
  std::vector<std::pair<float, double>> quality_and_sum;  // (best jump full-D distance, weight sum)
  for (int p = 0; p < r.pixel_count(); ++p) {
    double sum = 0;
    for (int i = 0; i < k; ++i) {
      const float w = r.jump_map.weights[size_t(p) * k + i];
      ASSERT_GE(w, 0.0f);
      if (r.jump_map.targets[size_t(p) * k + i] < 0) ASSERT_EQ(w, 0.0f);
      sum += w;
    }
    ASSERT_LE(sum, 1.0 + 1e-6) << "pixel " << p;
    const int t = r.jump_map.targets[size_t(p) * k];
    if (t >= 0) quality_and_sum.emplace_back(texsynth::squared_distance(full_->row(p), full_->row(t), full_->dims), sum);
  }
  // Pixels whose best match is in the worst decile carry clearly less jump probability than the best decile.
  std::sort(quality_and_sum.begin(), quality_and_sum.end());
  const size_t tenth = quality_and_sum.size() / 10;
  double best = 0, worst = 0;
  for (size_t i = 0; i < tenth; ++i) {
    best += quality_and_sum[i].second;
    worst += quality_and_sum[quality_and_sum.size() - 1 - i].second;
  }
  EXPECT_LT(worst, 0.5 * best);
  EXPECT_GT(best / tenth, 0.9);  // good matches share (nearly) the full probability
}

TEST(JumpMap, TileableExclusionWrapsAround) {
  texsynth::PreprocessParams params;
  params.tileable = true;
  params.neighbourhood = 7;
  const auto r = texsynth::preprocess(texsynth_test::brick_texture(40, 36, 6), params);
  int jumps = 0;
  for (int p = 0; p < r.pixel_count(); ++p)
    for (int i = 0; i < r.jump_map.k; ++i) {
      const int t = r.jump_map.targets[size_t(p) * r.jump_map.k + i];
      if (t < 0) continue;
      ++jumps;
      ASSERT_GT(chebyshev(p, t, r.width, r.height, true), 3) << p << " -> " << t;
    }
  EXPECT_GT(jumps, r.pixel_count() * 3);
}

}  // namespace
