// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>
#include <map>
#include <set>

#include "preprocess_threads.hpp"
#include "synthetic_texture.hpp"
#include "texsynth/common/rng.hpp"
#include "texsynth/preprocess/kmeans.hpp"
#include "texsynth/preprocess/preprocess.hpp"

namespace {

texsynth::Features random_points(int count, int dims, uint64_t seed) {
  texsynth::Features f;
  f.count = count;
  f.dims = dims;
  f.values.resize(size_t(count) * dims);
  texsynth::Rng rng(seed);
  for (float& v : f.values) v = float(rng.uniform());
  return f;
}

TEST(KMeans, RecoversPlantedClusters) {
  // 12 well-separated centres in 6-D, points in random order with small noise.
  const int k = 12, dims = 6, per = 400;
  const texsynth::Features centres = random_points(k, dims, 5);
  texsynth::Features points;
  points.count = k * per;
  points.dims = dims;
  points.values.resize(size_t(points.count) * dims);
  std::vector<int> planted(size_t(points.count));
  texsynth::Rng rng(9);
  for (int i = 0; i < points.count; ++i) {
    const int c = int(rng.below(k));
    planted[size_t(i)] = c;
    for (int d = 0; d < dims; ++d)
      points.values[size_t(i) * dims + d] = centres.values[size_t(c) * dims + d] * 20.0f + float(rng.uniform() - 0.5);
  }
  texsynth::KMeansParams params;
  params.num_clusters = k;
  params.seed = 3;
  const texsynth::KMeansResult result = texsynth::kmeans(points, params);
  // Every found cluster holds exactly one planted cluster and vice versa.
  std::map<int, std::set<int>> found_to_planted, planted_to_found;
  for (int i = 0; i < points.count; ++i) {
    found_to_planted[result.labels[size_t(i)]].insert(planted[size_t(i)]);
    planted_to_found[planted[size_t(i)]].insert(result.labels[size_t(i)]);
  }
  EXPECT_EQ(found_to_planted.size(), size_t(k));
  for (const auto& [f, ps] : found_to_planted) EXPECT_EQ(ps.size(), 1u) << "cluster " << f << " mixes planted clusters";
  for (const auto& [p, fs] : planted_to_found) EXPECT_EQ(fs.size(), 1u) << "planted " << p << " was split";
}

TEST(KMeans, PrunedAssignmentIsExactNearestCentre) {
  // K above the pruning list length (192) exercises the exhaustive fallback too.
  for (int k : {40, 300}) {
    const texsynth::Features points = random_points(6000, 8, 11 + k);
    texsynth::KMeansParams params;
    params.num_clusters = k;
    params.subsample_size = 2000;
    const texsynth::KMeansResult result = texsynth::kmeans(points, params);
    EXPECT_EQ(result.labels, texsynth::assign_brute_force(points, result.centres, k)) << "K=" << k;
    EXPECT_LE(result.last_change_fraction, 0.01);
  }
}

TEST(KMeans, ClusteringBeatsRandomLabelsByFar) {
  const texsynth::Features points = random_points(5000, 4, 2);
  texsynth::KMeansParams params;
  params.num_clusters = 50;
  const auto result = texsynth::kmeans(points, params);
  std::vector<int32_t> random_labels(5000);
  texsynth::Rng rng(1);
  for (auto& l : random_labels) l = int32_t(rng.below(50));
  EXPECT_LT(texsynth::within_cluster_sse(points, result.labels, 50),
            0.25 * texsynth::within_cluster_sse(points, random_labels, 50));
}

// The two centre-update rules (textons, particle classes): the same means up to the division, and
// an empty cluster reseeded at one of the points or left where it was.
TEST(KMeans, CentreUpdateRules) {
  const std::vector<float> points = {0.f, 0.f, 1.f, 0.f, 0.f, 3.f, 10.f, 10.f};  // 4 points, 2 dims
  const std::vector<int32_t> labels = {0, 0, 0, 1};
  const std::vector<float> before = {5.f, 5.f, 6.f, 6.f, 7.f, 7.f};  // 3 clusters; cluster 2 is empty
  std::vector<float> texton = before, particle = before;
  texsynth::update_centres(points.data(), 4, 2, labels.data(), 3, 9, 0, texsynth::MeanRule{}, texton);
  texsynth::update_centres(points.data(), 4, 2, labels.data(), 3, 9, 0, texsynth::MeanRule{false, false}, particle);
  for (const auto* c : {&texton, &particle}) {
    EXPECT_FLOAT_EQ((*c)[0], 1.f / 3.f);
    EXPECT_FLOAT_EQ((*c)[1], 1.f);
    EXPECT_EQ((*c)[2], 10.f);
    EXPECT_EQ((*c)[3], 10.f);
  }
  EXPECT_EQ(particle[4], 7.f);
  EXPECT_EQ(particle[5], 7.f);
  bool at_a_point = false;
  for (int i = 0; i < 4; ++i) at_a_point |= texton[4] == points[2 * i] && texton[5] == points[2 * i + 1];
  EXPECT_TRUE(at_a_point);
}

TEST(KMeans, RejectsMoreClustersThanPoints) {
  const texsynth::Features points = random_points(10, 3, 1);
  texsynth::KMeansParams params;
  params.num_clusters = 11;
  EXPECT_THROW(texsynth::kmeans(points, params), std::invalid_argument);
}

class TextonTables : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    texsynth::PreprocessParams params;
    params.num_textons = 40;
    result_ = new texsynth::Preprocessed(texsynth::preprocess(texsynth_test::brick_texture(72, 60), params));
  }
  static void TearDownTestSuite() { delete result_; }
  static texsynth::Preprocessed* result_;
};
texsynth::Preprocessed* TextonTables::result_ = nullptr;

TEST_F(TextonTables, BucketArrayPartitionsPixels) {
  const auto& r = *result_;
  const int n = r.pixel_count();
  ASSERT_EQ(r.bucket_start.size(), size_t(r.num_textons) + 1);
  EXPECT_EQ(r.bucket_start.front(), 0);
  EXPECT_EQ(r.bucket_start.back(), n);
  std::vector<int> seen(size_t(n), 0);
  for (int t = 0; t < r.num_textons; ++t) {
    ASSERT_LE(r.bucket_start[size_t(t)], r.bucket_start[size_t(t) + 1]);
    for (int i = r.bucket_start[size_t(t)]; i < r.bucket_start[size_t(t) + 1]; ++i) {
      const int p = r.bucket_pixels[size_t(i)];
      ASSERT_GE(p, 0);
      ASSERT_LT(p, n);
      ++seen[size_t(p)];
      EXPECT_EQ(r.texton_map[size_t(p)], t);
    }
  }
  for (int p = 0; p < n; ++p) ASSERT_EQ(seen[size_t(p)], 1) << "pixel " << p;
}

TEST_F(TextonTables, DistanceTableIsSymmetricZeroDiagonalAndDirect) {
  const auto& r = *result_;
  const int k = r.num_textons, d = r.texton_dims;
  ASSERT_EQ(r.texton_distances.size(), size_t(k) * k);
  for (int i = 0; i < k; ++i)
    for (int j = 0; j < k; ++j) {
      double direct = 0;
      for (int c = 0; c < d; ++c) {
        const double diff = double(r.textons[size_t(i) * d + c]) - r.textons[size_t(j) * d + c];
        direct += diff * diff;
      }
      const float table = r.texton_distances[size_t(i) * k + j];
      EXPECT_EQ(table, r.texton_distances[size_t(j) * k + i]);
      if (i == j) EXPECT_EQ(table, 0.0f);
      EXPECT_NEAR(table, direct, 1e-4 * (1 + direct));
    }
}

TEST_F(TextonTables, TextonsAreDistinctAndUsed) {
  const auto& r = *result_;
  EXPECT_EQ(r.num_textons, 40);
  EXPECT_EQ(r.texton_dims, 16);
  for (int t = 0; t < r.num_textons; ++t) EXPECT_GT(r.bucket_start[size_t(t) + 1], r.bucket_start[size_t(t)]);
}

TEST(Preprocess, DefaultTextonCountIsSqrtOfPixels) {
  texsynth::PreprocessParams params;
  EXPECT_EQ(texsynth::resolved_num_textons(params, 256 * 256), 256);
  EXPECT_EQ(texsynth::resolved_num_textons(params, 100 * 30), 55);  // sqrt(3000) = 54.77
  params.num_textons = 7;
  EXPECT_EQ(texsynth::resolved_num_textons(params, 256 * 256), 7);
}

TEST(Preprocess, BitIdenticalForOneAndTwoThreads) {
  // 160x140 > 20000 pixels: k-means also runs its subsample phase.
  const texsynth::Image image = texsynth_test::brick_texture(160, 140, 4);
  texsynth::PreprocessParams params;
  params.seed = 17;
  const texsynth::Preprocessed one = texsynth_test::expect_same_at_one_and_two_threads(image, params);
  params.seed = 18;
  const texsynth::Preprocessed other = texsynth::preprocess(image, params);
  EXPECT_NE(one.textons, other.textons) << "seed has no effect";
  // 320x300 > 4 x 20000 pixels: the single assignment pass after the subsample.
  texsynth_test::expect_same_at_one_and_two_threads(texsynth_test::brick_texture(320, 300, 4), params);
}

TEST(KMeans, SingleAssignmentPassIsExactNearestCentre) {
  const texsynth::Features points = random_points(20000, 8, 5);
  texsynth::KMeansParams params;
  params.num_clusters = 40;
  params.subsample_size = 2000;  // a tenth of the points: one pass over all of them
  const texsynth::KMeansResult result = texsynth::kmeans(points, params);
  EXPECT_EQ(result.iterations, 0);
  EXPECT_EQ(result.labels, texsynth::assign_brute_force(points, result.centres, 40));
  params.full_lloyd = true;
  const texsynth::KMeansResult full = texsynth::kmeans(points, params);
  EXPECT_GT(full.iterations, 0);
  // Within-cluster SSE of the single pass stays close to Lloyd on every point.
  EXPECT_LT(texsynth::within_cluster_sse(points, result.labels, 40),
            1.05 * texsynth::within_cluster_sse(points, full.labels, 40));
}

TEST(Preprocess, TileableUsesPeriodicNeighbourhoods) {
  // A horizontally periodic pattern: with tileable, columns 0 and width-1 are neighbours, so the
  // feature of the left column equals that of the column one period further.
  const int w = 48, h = 24;
  std::vector<float> pixels(size_t(w) * h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) pixels[size_t(y) * w + x] = float((x * 5 + y * 3) % 16 == 0 || (x % 16) == 3);
  const texsynth::Image image = texsynth::image_from_pixels(pixels.data(), texsynth::PixelType::kFloat32, w, h, 1);
  const auto periodic = texsynth::compute_features(image, 7, 0, true, 0);
  const auto mirrored = texsynth::compute_features(image, 7, 0, false, 0);
  auto same = [&](const texsynth::Features& f, int a, int b) {
    return std::equal(f.row(a), f.row(a) + f.dims, f.row(b));
  };
  EXPECT_TRUE(same(periodic, 5 * w + 0, 5 * w + 16));   // period 16 in x, wraps around the edge
  EXPECT_FALSE(same(mirrored, 5 * w + 0, 5 * w + 16));  // mirrored borders break the period
  EXPECT_TRUE(same(mirrored, 5 * w + 20, 5 * w + 36));  // interior: identical either way
}

TEST(Preprocess, MirroredBordersAreUnbiased) {
  // A constant image must give the same feature at the corner as in the middle (no zero padding).
  std::vector<float> grey(30 * 30, 0.4f);
  const auto image = texsynth::image_from_pixels(grey.data(), texsynth::PixelType::kFloat32, 30, 30, 1);
  const auto f = texsynth::compute_features(image, 11, 0, false, 0);
  for (int d = 0; d < f.dims; ++d) EXPECT_NEAR(f.row(0)[d], f.row(15 * 30 + 15)[d], 1e-5);
}

}  // namespace

namespace {

TEST(KMeans, CentreIndexListsCentresByDistanceThenIndexSelfFirst) {
  // Duplicated centres (distance 0 to another centre, lower index) and equal distances: the order is
  // self, then (distance, index) ascending, whatever the list length.
  const int k = 7, dims = 2;
  const std::vector<float> centres = {0, 0, 0, 0, 1, 0, 0, 1, -1, 0, 3, 4, 0, 0};  // 0, 1, 6 coincide
  const std::vector<float> table = texsynth::centre_distance_table(centres, k, dims);
  for (int length : {1, 3, k}) {
    const texsynth::CentreIndex index = texsynth::build_centre_index(table, k, length);
    for (int c = 0; c < k; ++c) {
      std::vector<std::pair<float, int>> expected;
      for (int j = 0; j < k; ++j)
        if (j != c) expected.push_back({table[size_t(c) * k + j], j});
      std::sort(expected.begin(), expected.end());
      EXPECT_EQ(index.nearest(c)[0], c);
      EXPECT_EQ(index.nearest_distance(c)[0], 0.0f);
      for (int j = 1; j < length; ++j) {
        EXPECT_EQ(index.nearest(c)[j], expected[size_t(j - 1)].second) << "centre " << c << " rank " << j;
        EXPECT_FLOAT_EQ(index.nearest_distance(c)[j], std::sqrt(expected[size_t(j - 1)].first));
      }
    }
  }
}

}  // namespace
