// SPDX-License-Identifier: GPL-3.0-or-later
// Bake-margin dilation against a brute-force nearest-covered-pixel search and hand-counted disks.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <vector>

#include "texsynth/common/rng.hpp"
#include "texsynth/surface/dilate.hpp"
#include "texsynth/surface/texel_samples.hpp"

using texsynth::dilate_margin;
using texsynth::find_margin_pixels;

namespace {

bool same_bits(const float* a, const float* b, size_t n) { return std::memcmp(a, b, n * sizeof(float)) == 0; }

// Random blobs of coverage, random colours; uncovered pixels hold NaN (garbage the margin must not read).
struct Scene {
  int w, h;
  std::vector<uint8_t> mask;
  std::vector<float> image;
};
Scene random_scene(int w, int h, uint64_t seed) {
  Scene s{w, h, std::vector<uint8_t>(size_t(w) * h, 0), std::vector<float>(size_t(w) * h * 4)};
  texsynth::Rng rng(seed);
  for (int blob = 0; blob < 6; ++blob) {
    const double cx = rng.uniform() * w, cy = rng.uniform() * h, r = 1 + rng.uniform() * 4;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        if ((x - cx) * (x - cx) + (y - cy) * (y - cy) <= r * r) s.mask[y * w + x] = 1;
  }
  for (size_t p = 0; p < s.mask.size(); ++p)
    for (int c = 0; c < 4; ++c)
      s.image[4 * p + c] = s.mask[p] ? float(rng.uniform()) : std::numeric_limits<float>::quiet_NaN();
  return s;
}

// Nearest covered pixel within margin (Euclidean), lowest index on ties, or -1.
int brute_nearest(const Scene& s, int p, int margin) {
  int best = -1, best_d2 = margin * margin + 1;
  for (int q = 0; q < s.w * s.h; ++q) {
    if (!s.mask[q]) continue;
    const int dx = p % s.w - q % s.w, dy = p / s.w - q / s.w;
    if (dx * dx + dy * dy < best_d2) best_d2 = dx * dx + dy * dy, best = q;
  }
  return best;
}

}  // namespace

TEST(SurfaceDilate, SingleCoveredPixelFillsTheDiskOfRadiusMargin) {
  const int w = 11, h = 9;
  std::vector<uint8_t> mask(w * h, 0);
  mask[4 * w + 5] = 1;
  std::vector<float> image(size_t(w) * h * 4, 0.25f);
  const float colour[4] = {0.1f, 0.2f, 0.3f, 1.0f};
  std::memcpy(&image[4 * (4 * w + 5)], colour, sizeof colour);
  const auto out = dilate_margin(image.data(), mask.data(), w, h, 4, 2);
  int filled = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int d2 = (x - 5) * (x - 5) + (y - 4) * (y - 4);
      const float* px = &out[4 * size_t(y * w + x)];
      if (d2 <= 4) {
        EXPECT_TRUE(same_bits(px, colour, 4)) << x << "," << y;
        filled += d2 > 0;
      } else {
        for (int c = 0; c < 4; ++c) EXPECT_EQ(px[c], 0.25f) << x << "," << y;
      }
    }
  EXPECT_EQ(filled, 12);  // 13 offsets with dx^2 + dy^2 <= 4, minus the pixel itself
}

TEST(SurfaceDilate, MatchesBruteForceNearestAndLeavesTheRestAlone) {
  for (int margin : {1, 2, 5}) {
    const Scene s = random_scene(37, 29, 7 + margin);
    const auto out = dilate_margin(s.image.data(), s.mask.data(), s.w, s.h, 4, margin);
    ASSERT_EQ(out.size(), s.image.size());
    int margin_pixels = 0;
    for (int p = 0; p < s.w * s.h; ++p) {
      const float* got = &out[4 * size_t(p)];
      if (s.mask[p]) {
        EXPECT_TRUE(same_bits(got, &s.image[4 * size_t(p)], 4)) << "covered pixel " << p << " changed";
        continue;
      }
      const int q = brute_nearest(s, p, margin);
      if (q < 0) {
        EXPECT_TRUE(same_bits(got, &s.image[4 * size_t(p)], 4)) << "far pixel " << p << " touched";
      } else {
        ++margin_pixels;
        EXPECT_TRUE(same_bits(got, &s.image[4 * size_t(q)], 4)) << "pixel " << p << " should copy " << q;
        for (int c = 0; c < 4; ++c) EXPECT_TRUE(std::isfinite(got[c]));
      }
    }
    EXPECT_GT(margin_pixels, 0);
  }
}

TEST(SurfaceDilate, TiesGoToTheLowestPixelIndex) {
  // Covered pixels at x = 2 and x = 6 of one row: x = 4 is 2 away from both -> the left one.
  const int w = 9, h = 3;
  std::vector<uint8_t> mask(w * h, 0);
  mask[w + 2] = mask[w + 6] = 1;
  std::vector<float> image(w * h, 0.f);
  image[w + 2] = 1.f;
  image[w + 6] = 2.f;
  const auto out = dilate_margin(image.data(), mask.data(), w, h, 1, 2);
  EXPECT_EQ(out[w + 4], 1.f);
  EXPECT_EQ(out[w + 5], 2.f);
  EXPECT_EQ(out[w + 3], 1.f);
  // Vertical tie: rows 0 and 2 covered at column 4, pixel (4, 1) between them -> the row above (lower index).
  std::vector<uint8_t> vmask(w * h, 0);
  vmask[4] = vmask[2 * w + 4] = 1;
  std::vector<float> vimage(w * h, 0.f);
  vimage[4] = 3.f;
  vimage[2 * w + 4] = 4.f;
  EXPECT_EQ(dilate_margin(vimage.data(), vmask.data(), w, h, 1, 1)[w + 4], 3.f);
}

TEST(SurfaceDilate, MarginZeroAndEmptyMaskCopyTheImage) {
  const Scene s = random_scene(16, 12, 3);
  auto out = dilate_margin(s.image.data(), s.mask.data(), s.w, s.h, 4, 0);
  EXPECT_TRUE(same_bits(out.data(), s.image.data(), out.size()));
  std::vector<uint8_t> none(s.mask.size(), 0);
  out = dilate_margin(s.image.data(), none.data(), s.w, s.h, 4, 3);
  EXPECT_TRUE(same_bits(out.data(), s.image.data(), out.size()));
}

TEST(SurfaceDilate, MaskAndOwnerOverloadsAgreeAndThreadsDoNotMatter) {
  const Scene s = random_scene(300, 170, 11);
  std::vector<int32_t> owner(s.mask.size());
  for (size_t p = 0; p < owner.size(); ++p) owner[p] = s.mask[p] ? int32_t(p % 7) : -1;
  texsynth::MarginPixels a, b, c;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    a = find_margin_pixels(s.mask.data(), s.w, s.h, 4);
  }
  {
    tbb::global_control two(tbb::global_control::max_allowed_parallelism, 2);
    b = find_margin_pixels(s.mask.data(), s.w, s.h, 4);
    c = find_margin_pixels(owner.data(), s.w, s.h, 4);
  }
  EXPECT_FALSE(a.pixel.empty());
  EXPECT_EQ(a.pixel, b.pixel);
  EXPECT_EQ(a.source, b.source);
  EXPECT_EQ(a.pixel, c.pixel);
  EXPECT_EQ(a.source, c.source);
}

TEST(SurfaceDilate, RejectsBadArguments) {
  std::vector<float> image(16, 0.f);
  std::vector<uint8_t> mask(4, 0);
  EXPECT_THROW(dilate_margin(image.data(), mask.data(), 0, 4, 4, 1), std::invalid_argument);
  EXPECT_THROW(dilate_margin(image.data(), mask.data(), 2, 2, 0, 1), std::invalid_argument);
  EXPECT_THROW(dilate_margin(image.data(), mask.data(), 2, 2, 4, -1), std::invalid_argument);
  EXPECT_THROW(dilate_margin(image.data(), mask.data(), 2, 2, 4, texsynth::kMaxMarginTexels + 1), std::invalid_argument);
  EXPECT_THROW(dilate_margin(nullptr, mask.data(), 2, 2, 4, 1), std::invalid_argument);
}
