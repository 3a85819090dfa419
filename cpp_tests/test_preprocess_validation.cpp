// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>

#include <limits>

#include "synthetic_texture.hpp"
#include "temp_dir.hpp"
#include "texsynth/preprocess/preprocess.hpp"

namespace {

void expect_rejected(const texsynth::Image& image, const texsynth::PreprocessParams& params, const std::string& fragment) {
  texsynth_test::TempDir dir;
  const std::string cache = dir.file("cache");
  try {
    texsynth::preprocess_cached(image, params, cache);
    FAIL() << "accepted; expected an error mentioning '" << fragment << "'";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(cache)) << "bad input must write nothing";
  EXPECT_THROW(texsynth::preprocess(image, params), std::invalid_argument);
}

TEST(PreprocessValidation, RejectsEveryBadInputWithAClearMessage) {
  const texsynth::Image good = texsynth_test::brick_texture(32, 24);
  texsynth::PreprocessParams params;
  const float one = 0.5f;
  expect_rejected(texsynth::image_from_pixels(&one, texsynth::PixelType::kFloat32, 1, 1, 1), params, "smaller than");
  expect_rejected(texsynth_test::brick_texture(10, 40), params, "smaller than the 11x11");
  for (int n : {10, 0, -3, 1}) {
    params.neighbourhood = n;
    expect_rejected(good, params, "neighbourhood must be an odd number");
  }
  params.neighbourhood = 27;
  expect_rejected(texsynth_test::brick_texture(40, 40), params, "between 3 and 25");
  params = {};
  params.num_textons = 32 * 24 + 1;
  expect_rejected(good, params, "exceeds the sample's pixel count");
  params = {};
  params.jump_candidates = 0;
  expect_rejected(good, params, "jump_candidates");
  params = {};
  texsynth::Image nan = good;
  nan.pixels[77] = std::numeric_limits<float>::quiet_NaN();
  expect_rejected(nan, params, "NaN");
  texsynth::Image inf = good;
  inf.pixels[5] = -std::numeric_limits<float>::infinity();
  expect_rejected(inf, params, "infinite");
}

TEST(PreprocessValidation, RefusesFeatureSetsBeyondTheMemoryLimit) {
  // 2000x2000 gray with full 121-D features would need ~1.9 GB of features: refused up front.
  std::vector<uint8_t> gray(2000 * 2000, 128);
  const auto image = texsynth::image_from_pixels(gray.data(), texsynth::PixelType::kUint8, 2000, 2000, 1);
  texsynth::PreprocessParams params;
  params.feature_dims = 0;
  params.num_textons = 10;
  params.working_size = 0;  // at its own resolution (1024 would analyse 1024² and fit)
  expect_rejected(image, params, "memory limit");
}

TEST(PreprocessValidation, AcceptsTheSmallestValidSample) {
  texsynth::PreprocessParams params;
  params.neighbourhood = 3;
  const auto r = texsynth::preprocess(texsynth_test::brick_texture(3, 3), params);
  EXPECT_EQ(r.num_textons, 3);
  // 3x3 with n = 3 (exclusion radius 1): the centre pixel touches every pixel, so it has no jumps;
  // corners may only jump to pixels two rows or columns away.
  for (int i = 0; i < r.jump_map.k; ++i) {
    EXPECT_EQ(r.jump_map.targets[size_t(4) * r.jump_map.k + i], -1);
    EXPECT_EQ(r.jump_map.weights[size_t(4) * r.jump_map.k + i], 0.0f);
  }
  for (int p = 0; p < 9; ++p)
    for (int i = 0; i < r.jump_map.k; ++i) {
      const int t = r.jump_map.targets[size_t(p) * r.jump_map.k + i];
      if (t >= 0) EXPECT_GE(std::max(std::abs(t % 3 - p % 3), std::abs(t / 3 - p / 3)), 2) << p << "->" << t;
    }
}

}  // namespace
