// SPDX-License-Identifier: GPL-3.0-or-later
// texsynth::gaussian_blur: a point spreads into the normalised Gaussian, clamped borders keep the mean of a
// constant image, wrapped borders carry what leaves one side into the other, and the bytes do not depend on
// the thread count.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <vector>

#include "texsynth/image/blur.hpp"

namespace {

TEST(ImageBlur, APointSpreadsIntoTheNormalisedGaussian) {
  const int w = 21, h = 21;
  std::vector<float> px(size_t(w) * h, 0.f);
  px[size_t(10) * w + 10] = 1.f;
  const double sigma = 1.5;
  const std::vector<float> out = texsynth::gaussian_blur(px.data(), w, h, 1, sigma, false);
  double total = 0;
  for (float v : out) total += v;
  EXPECT_NEAR(total, 1.0, 1e-5);
  // Separable: the value at (10 + dx, 10 + dy) is g(dx) g(dy) with g the normalised 1-D kernel.
  double norm = 0;
  for (int i = -5; i <= 5; ++i) norm += std::exp(-0.5 * i * i / (sigma * sigma));
  for (int dy = -3; dy <= 3; ++dy)
    for (int dx = -3; dx <= 3; ++dx) {
      const double expected = std::exp(-0.5 * (dx * dx + dy * dy) / (sigma * sigma)) / (norm * norm);
      EXPECT_NEAR(out[size_t(10 + dy) * w + 10 + dx], expected, 1e-6) << dx << "," << dy;
    }
  // sigma 0 copies.
  EXPECT_EQ(texsynth::gaussian_blur(px.data(), w, h, 1, 0.0, false), px);
}

TEST(ImageBlur, BordersClampOrWrap) {
  const int w = 16, h = 8, c = 2;
  std::vector<float> constant(size_t(w) * h * c, 0.25f);
  for (float v : texsynth::gaussian_blur(constant.data(), w, h, c, 2.0, false)) EXPECT_NEAR(v, 0.25f, 1e-6);
  // A bright first column: wrapped, the last column receives as much as the second; clamped, almost nothing.
  std::vector<float> column(size_t(w) * h * c, 0.f);
  for (int y = 0; y < h; ++y) column[(size_t(y) * w) * c] = 1.f;
  const std::vector<float> wrapped = texsynth::gaussian_blur(column.data(), w, h, c, 1.0, true);
  const std::vector<float> clamped = texsynth::gaussian_blur(column.data(), w, h, c, 1.0, false);
  const size_t second = size_t(4 * w + 1) * c, last = size_t(4 * w + w - 1) * c;
  EXPECT_NEAR(wrapped[last], wrapped[second], 1e-6);
  EXPECT_GT(wrapped[last], 0.2f);
  EXPECT_LT(clamped[last], 1e-6f);
  EXPECT_EQ(wrapped[second + 1], 0.f);  // channels stay apart
}

TEST(ImageBlur, SameBytesAtOneAndTwoThreads) {
  const int w = 67, h = 53, c = 3;
  std::vector<float> px(size_t(w) * h * c);
  for (size_t i = 0; i < px.size(); ++i) px[i] = float((i * 2654435761u) % 1000) / 1000.f;
  std::vector<float> one, two;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    one = texsynth::gaussian_blur(px.data(), w, h, c, 1.7, true);
  }
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
    two = texsynth::gaussian_blur(px.data(), w, h, c, 1.7, true);
  }
  EXPECT_EQ(one, two);
}

}  // namespace
