// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <thread>

#include "synthetic_texture.hpp"
#include "temp_dir.hpp"
#include "texsynth/common/rng.hpp"
#include "texsynth/preprocess/gaussianize.hpp"

namespace {

using texsynth::HistogramTransform;
using texsynth::Image;

Image make_image(int width, int height, int channels) {
  Image image;
  image.width = width;
  image.height = height;
  image.channels = channels;
  image.encoding = texsynth::ColorEncoding::kSrgb;
  image.pixels.assign(size_t(width) * height * channels, 0.0f);
  return image;
}

Image random_image(int width, int height, int channels, uint64_t seed) {
  Image image = make_image(width, height, channels);
  texsynth::Rng rng(seed);
  for (float& v : image.pixels) v = float(rng.uniform());
  return image;
}

// Many ties: every value is one of 256 levels, as in an 8-bit sample.
Image quantised_image(int width, int height, int channels, uint64_t seed) {
  Image image = random_image(width, height, channels, seed);
  for (float& v : image.pixels) v = std::floor(v * 255.0f) / 255.0f;
  return image;
}

float value(const std::vector<float>& data, const Image& image, size_t pixel, int channel) {
  return data[pixel * image.channels + channel];
}

void expect_all_finite(const HistogramTransform& t) {
  for (float v : t.gaussian) ASSERT_TRUE(std::isfinite(v));
  for (float v : t.inverse_lut) ASSERT_TRUE(std::isfinite(v));
}

void expect_identity_lut(const HistogramTransform& t, int channel) {
  for (int i = 0; i < t.lut_size; ++i)
    ASSERT_EQ(t.inverse_lut[size_t(i) * t.channels + channel], float((i + 0.5) / t.lut_size)) << "entry " << i;
}

void expect_same(const HistogramTransform& a, const HistogramTransform& b) {
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  EXPECT_EQ(a.channels, b.channels);
  EXPECT_EQ(a.colour_channels, b.colour_channels);
  EXPECT_EQ(a.lut_size, b.lut_size);
  EXPECT_EQ(a.ok, b.ok);
  EXPECT_EQ(a.fallback_reason, b.fallback_reason);
  EXPECT_EQ(a.min_distinct_values, b.min_distinct_values);
  EXPECT_TRUE(a.gaussian == b.gaussian);
  EXPECT_TRUE(a.inverse_lut == b.inverse_lut);
}

TEST(Gaussianize, NormalQuantileInvertsTheCdf) {
  EXPECT_EQ(texsynth::normal_quantile(0.5), 0.0);
  EXPECT_NEAR(texsynth::normal_quantile(0.975), 1.959963984540054, 1e-13);
  EXPECT_NEAR(texsynth::normal_quantile(0.8413447460685429), 1.0, 1e-12);
  EXPECT_TRUE(std::isinf(texsynth::normal_quantile(0.0)) && texsynth::normal_quantile(0.0) < 0);
  EXPECT_TRUE(std::isinf(texsynth::normal_quantile(1.0)) && texsynth::normal_quantile(1.0) > 0);
  for (double p : {1e-300, 1e-12, 3e-8, 1e-4, 0.02, 0.02425, 0.1, 0.3, 0.4999, 0.6, 0.9, 0.97575, 0.999, 1 - 1e-9}) {
    const double x = texsynth::normal_quantile(p);
    const double tail = std::min(p, 1 - p);  // exact: 1 - p needs no rounding for p >= 0.5
    EXPECT_NEAR(texsynth::normal_cdf(-std::fabs(x)), tail, 1e-13 * tail) << p;
    if (1 - (1 - p) == p) EXPECT_EQ(texsynth::normal_quantile(1 - p), -x) << p;
  }
}

TEST(Gaussianize, ChannelsBecomeGaussianWithMeanHalfAndStdOneSixth) {
  const Image image = random_image(256, 256, 3, 11);
  const HistogramTransform t = texsynth::gaussianize(image);
  ASSERT_TRUE(t.ok) << t.fallback_reason;
  EXPECT_EQ(t.colour_channels, 3);
  EXPECT_EQ(t.lut_size, 1024);
  ASSERT_EQ(t.gaussian.size(), image.pixels.size());
  ASSERT_EQ(t.inverse_lut.size(), size_t(1024) * 3);
  const size_t n = size_t(image.pixel_count());
  for (int c = 0; c < 3; ++c) {
    double sum = 0, sum2 = 0;
    size_t within_one_std = 0;
    for (size_t p = 0; p < n; ++p) {
      const double g = value(t.gaussian, image, p, c);
      ASSERT_GE(g, 0.0);
      ASSERT_LE(g, 1.0);
      sum += g;
      sum2 += g * g;
      within_one_std += std::fabs(g - 0.5) <= 1.0 / 6.0;
    }
    const double mean = sum / n, std_dev = std::sqrt(sum2 / n - mean * mean);
    EXPECT_NEAR(mean, 0.5, 1e-4) << "channel " << c;
    // Clamping at ±3σ leaves 99.75% of σ.
    EXPECT_NEAR(std_dev, 1.0 / 6.0, 0.01 / 6.0) << "channel " << c;
    EXPECT_NEAR(double(within_one_std) / n, 0.6827, 0.002) << "channel " << c;
  }
}

TEST(Gaussianize, RanksArePreservedAndTiesMapTogether) {
  const Image image = quantised_image(97, 61, 3, 5);
  const HistogramTransform t = texsynth::gaussianize(image);
  ASSERT_TRUE(t.ok) << t.fallback_reason;
  const size_t n = size_t(image.pixel_count());
  for (int c = 0; c < 3; ++c) {
    std::vector<size_t> order(n);
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(),
              [&](size_t a, size_t b) { return value(image.pixels, image, a, c) < value(image.pixels, image, b, c); });
    for (size_t i = 1; i < n; ++i) {
      const float x0 = value(image.pixels, image, order[i - 1], c), x1 = value(image.pixels, image, order[i], c);
      const float g0 = value(t.gaussian, image, order[i - 1], c), g1 = value(t.gaussian, image, order[i], c);
      if (x0 == x1) {
        ASSERT_EQ(g0, g1) << "equal inputs, channel " << c;
      } else {
        ASSERT_LE(g0, g1) << "order, channel " << c;
      }
    }
  }
  // Negative zero is the same value as zero.
  Image signed_zero = random_image(8, 8, 1, 3);
  signed_zero.pixels[3] = -0.0f;
  signed_zero.pixels[40] = 0.0f;
  const HistogramTransform z = texsynth::gaussianize(signed_zero, 1024, 2);
  EXPECT_EQ(z.gaussian[3], z.gaussian[40]);
}

TEST(Gaussianize, InverseLutUndoesTheTransformAndIsMonotone) {
  // Smooth histogram: sum of value noises, unevenly spread, plus a wide range in channel 1.
  Image image = make_image(200, 150, 3);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      const float a = texsynth_test::value_noise(float(x), float(y), 5.0f, 1);
      const float b = texsynth_test::value_noise(float(x), float(y), 17.0f, 2);
      float* px = &image.pixels[(size_t(y) * image.width + x) * 3];
      px[0] = 0.7f * a + 0.3f * b;
      px[1] = 40.0f * a * a - 3.0f;
      px[2] = std::sqrt(b);
    }
  const HistogramTransform t = texsynth::gaussianize(image);
  ASSERT_TRUE(t.ok) << t.fallback_reason;
  const size_t n = size_t(image.pixel_count());
  for (int c = 0; c < 3; ++c) {
    float lo = HUGE_VALF, hi = -HUGE_VALF;
    for (size_t p = 0; p < n; ++p) {
      lo = std::min(lo, value(image.pixels, image, p, c));
      hi = std::max(hi, value(image.pixels, image, p, c));
    }
    for (int i = 0; i < t.lut_size; ++i) {
      const float v = t.inverse_lut[size_t(i) * 3 + c];
      ASSERT_GE(v, lo);
      ASSERT_LE(v, hi);
      if (i > 0) ASSERT_LE(t.inverse_lut[size_t(i - 1) * 3 + c], v) << "entry " << i << ", channel " << c;
    }
    // Between the first and last entry centres the LUT interpolates the sample's quantiles; beyond them
    // (|g - 0.5| > 3σ·(1 - 1/L), ~0.3% of pixels) it clamps, and sparse extreme tails land further off.
    double total_error = 0, worst_inside = 0;
    const float first_centre = 0.5f / t.lut_size, last_centre = 1.0f - first_centre;
    for (size_t p = 0; p < n; ++p) {
      const float g = value(t.gaussian, image, p, c);
      const double error = std::fabs(texsynth::inverse_lut_lookup(t, c, g) - value(image.pixels, image, p, c));
      total_error += error;
      if (g >= first_centre && g <= last_centre) worst_inside = std::max(worst_inside, error);
    }
    const double range = hi - lo;
    EXPECT_LT(total_error / n, 0.001 * range) << "channel " << c;
    EXPECT_LT(worst_inside, 0.01 * range) << "channel " << c;
  }
}

TEST(Gaussianize, ConstantOrTwoValuedChannelFallsBackToTheIdentity) {
  Image constant_blue = random_image(40, 30, 3, 2);
  for (size_t p = 0; p < size_t(constant_blue.pixel_count()); ++p) constant_blue.pixels[p * 3 + 2] = 0.25f;
  HistogramTransform t = texsynth::gaussianize(constant_blue);
  EXPECT_FALSE(t.ok);
  EXPECT_EQ(t.fallback_reason, "channel 2 is constant");
  EXPECT_EQ(t.colour_channels, 3);
  EXPECT_TRUE(t.gaussian == constant_blue.pixels);
  expect_all_finite(t);
  for (int c = 0; c < 3; ++c) expect_identity_lut(t, c);

  Image two_valued = random_image(40, 30, 3, 3);
  for (size_t p = 0; p < size_t(two_valued.pixel_count()); ++p) two_valued.pixels[p * 3] = p % 3 ? 0.0f : 1.0f;
  t = texsynth::gaussianize(two_valued, 256);
  EXPECT_FALSE(t.ok);
  EXPECT_EQ(t.fallback_reason, "channel 0 has only 2 distinct values (at least 16 are needed)");
  EXPECT_TRUE(t.gaussian == two_valued.pixels);
  expect_all_finite(t);
  for (int c = 0; c < 3; ++c) expect_identity_lut(t, c);

  // The threshold is the caller's: 10 levels pass with 8 and fail with 16.
  Image ten_levels = random_image(40, 30, 1, 4);
  for (float& v : ten_levels.pixels) v = std::floor(v * 10.0f) / 10.0f;
  EXPECT_TRUE(texsynth::gaussianize(ten_levels, 1024, 8).ok);
  t = texsynth::gaussianize(ten_levels, 1024, 16);
  EXPECT_FALSE(t.ok);
  EXPECT_NE(t.fallback_reason.find("channel 0 has only 10 distinct values"), std::string::npos) << t.fallback_reason;

  // A single pixel, and an entirely flat image: every failing channel is named.
  const float one = 0.5f;
  t = texsynth::gaussianize(texsynth::image_from_pixels(&one, texsynth::PixelType::kFloat32, 1, 1, 1));
  EXPECT_FALSE(t.ok);
  EXPECT_EQ(t.fallback_reason, "channel 0 is constant");
  Image flat = make_image(16, 16, 4);
  t = texsynth::gaussianize(flat);
  EXPECT_EQ(t.fallback_reason, "channel 0 is constant; channel 1 is constant; channel 2 is constant");
  expect_all_finite(t);
  for (int c = 0; c < 4; ++c) expect_identity_lut(t, c);
}

TEST(Gaussianize, AlphaIsCopiedUnchangedWithAnIdentityColumn) {
  const Image rgba = random_image(50, 40, 4, 7);
  HistogramTransform t = texsynth::gaussianize(rgba, 64);
  ASSERT_TRUE(t.ok);
  EXPECT_EQ(t.colour_channels, 3);
  for (size_t p = 0; p < size_t(rgba.pixel_count()); ++p) ASSERT_EQ(t.gaussian[p * 4 + 3], rgba.pixels[p * 4 + 3]);
  expect_identity_lut(t, 3);

  Image grey_alpha = random_image(50, 40, 2, 8);
  for (size_t p = 0; p < size_t(grey_alpha.pixel_count()); ++p) grey_alpha.pixels[p * 2 + 1] = 1.0f;  // opaque
  t = texsynth::gaussianize(grey_alpha, 64);
  ASSERT_TRUE(t.ok) << "a constant alpha is not a colour channel";
  EXPECT_EQ(t.colour_channels, 1);
  for (size_t p = 0; p < size_t(grey_alpha.pixel_count()); ++p) ASSERT_EQ(t.gaussian[p * 2 + 1], 1.0f);
  expect_identity_lut(t, 1);
  EXPECT_EQ(texsynth::histogram_colour_channels(1), 1);
  EXPECT_EQ(texsynth::histogram_colour_channels(3), 3);
}

TEST(Gaussianize, RejectsBadParametersAndImages) {
  const Image image = random_image(20, 20, 3, 1);
  for (int lut_size : {-1, 0, 15, 65537}) {
    try {
      texsynth::gaussianize(image, lut_size);
      ADD_FAILURE() << "accepted lut_size " << lut_size;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("lut_size must be in [16, 65536]"), std::string::npos) << e.what();
    }
  }
  EXPECT_NO_THROW(texsynth::gaussianize(image, 16));
  for (int m : {0, 1, 65537}) EXPECT_THROW(texsynth::gaussianize(image, 1024, m), std::invalid_argument) << m;
  Image nan_image = image;
  nan_image.pixels[17] = std::nanf("");
  EXPECT_THROW(texsynth::gaussianize(nan_image), std::invalid_argument);
  Image inf_image = image;
  inf_image.pixels[5] = HUGE_VALF;
  EXPECT_THROW(texsynth::gaussianize(inf_image), std::invalid_argument);
  Image short_buffer = image;
  short_buffer.pixels.pop_back();
  EXPECT_THROW(texsynth::gaussianize(short_buffer), std::invalid_argument);

  // Bad input writes nothing.
  texsynth_test::TempDir dir;
  const std::string cache = dir.file("cache");
  EXPECT_THROW(texsynth::histogram_transform_cached(image, 1, cache, 8, 16), std::invalid_argument);
  EXPECT_THROW(texsynth::histogram_transform_cached(nan_image, 1, cache, 1024, 16), std::invalid_argument);
  EXPECT_FALSE(std::filesystem::exists(cache));
}

TEST(Gaussianize, IsDeterministic) {
  const Image image = quantised_image(300, 200, 4, 9);
  expect_same(texsynth::gaussianize(image, 512), texsynth::gaussianize(image, 512));
  const Image floats = random_image(300, 200, 3, 10);
  expect_same(texsynth::gaussianize(floats), texsynth::gaussianize(floats));
}

TEST(GaussianizeFiles, StemAndNames) {
  EXPECT_EQ(texsynth::histogram_file_stem("/c", 0xABCull, 1024), "/c/0000000000000abc-hist1024");
  EXPECT_EQ(texsynth::histogram_gaussian_path("/c/x"), "/c/x.gauss.exr");
  EXPECT_EQ(texsynth::histogram_lut_path("/c/x"), "/c/x.lut.exr");
}

TEST(GaussianizeFiles, SaveLoadRoundTripIsExact) {
  texsynth_test::TempDir dir;
  for (int channels = 1; channels <= 4; ++channels) {
    const Image image = random_image(33, 21, channels, 20 + channels);
    const HistogramTransform t = texsynth::gaussianize(image, 128);
    const std::string stem = dir.file("ok" + std::to_string(channels));
    texsynth::save_histogram_transform(t, stem);
    EXPECT_TRUE(std::filesystem::exists(stem + ".gauss.exr"));
    EXPECT_TRUE(std::filesystem::exists(stem + ".lut.exr"));
    const auto loaded = texsynth::load_histogram_transform(stem, 33, 21, channels, 128);
    ASSERT_TRUE(loaded) << channels << " channels";
    expect_same(t, *loaded);
  }
  Image flat = random_image(12, 9, 3, 1);
  for (size_t p = 0; p < 12 * 9; ++p) flat.pixels[p * 3 + 1] = -0.0f;
  const HistogramTransform fallback = texsynth::gaussianize(flat, 32);
  ASSERT_FALSE(fallback.ok);
  texsynth::save_histogram_transform(fallback, dir.file("fallback"));
  const auto loaded = texsynth::load_histogram_transform(dir.file("fallback"), 12, 9, 3, 32);
  ASSERT_TRUE(loaded);
  expect_same(fallback, *loaded);
  EXPECT_EQ(loaded->fallback_reason, "channel 1 is constant");
  // Nothing but the two files is left behind (temporary files were renamed).
  EXPECT_EQ(dir.entry_count(), 10u);
}

TEST(GaussianizeFiles, BadFilesLoadAsNulloptAndTheCacheRecomputes) {
  texsynth_test::TempDir dir;
  const Image image = random_image(64, 48, 4, 30);
  const uint64_t hash = texsynth::image_hash(image);
  const std::string cache = dir.file("cache");
  const HistogramTransform fresh = texsynth::histogram_transform_cached(image, hash, cache, 256, 16);
  const std::string stem = texsynth::histogram_file_stem(cache, hash, 256);
  const std::string gauss = texsynth::histogram_gaussian_path(stem), lut = texsynth::histogram_lut_path(stem);
  ASSERT_TRUE(texsynth::load_histogram_transform(stem, 64, 48, 4, 256));
  std::ifstream in(gauss, std::ios::binary);
  const std::vector<char> good((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_GT(good.size(), 1000u);

  // Wrong size, channel count or LUT size: nullopt.
  EXPECT_FALSE(texsynth::load_histogram_transform(stem, 63, 48, 4, 256));
  EXPECT_FALSE(texsynth::load_histogram_transform(stem, 64, 49, 4, 256));
  EXPECT_FALSE(texsynth::load_histogram_transform(stem, 64, 48, 3, 256));
  EXPECT_FALSE(texsynth::load_histogram_transform(stem, 64, 48, 4, 512));
  EXPECT_FALSE(texsynth::load_histogram_transform(dir.file("missing"), 64, 48, 4, 256));

  auto write = [](const std::string& path, const std::vector<char>& bytes) {
    std::ofstream(path, std::ios::binary | std::ios::trunc).write(bytes.data(), std::streamsize(bytes.size()));
  };
  auto expect_recomputed = [&](const std::string& what) {
    EXPECT_FALSE(texsynth::load_histogram_transform(stem, 64, 48, 4, 256)) << what;
    expect_same(texsynth::histogram_transform_cached(image, hash, cache, 256, 16), fresh);
    EXPECT_TRUE(texsynth::load_histogram_transform(stem, 64, 48, 4, 256)) << what << ": not rewritten";
  };
  write(gauss, std::vector<char>(good.begin(), good.begin() + std::ptrdiff_t(good.size() / 2)));
  expect_recomputed("truncated");
  std::vector<char> flipped = good;
  for (size_t i = good.size() / 2; i < good.size(); i += 7) flipped[i] = char(~flipped[i]);
  write(gauss, flipped);
  expect_recomputed("corrupt body");
  write(gauss, std::vector<char>(good.begin(), good.begin() + 40));
  expect_recomputed("header only");
  write(gauss, {});
  expect_recomputed("empty");
  write(lut, std::vector<char>(500, 'x'));
  expect_recomputed("garbage LUT");
  std::filesystem::remove(lut);
  expect_recomputed("missing LUT");

  // Non-finite values, a non-monotone LUT, out-of-range Gaussian values: stale.
  HistogramTransform broken = fresh;
  broken.inverse_lut[40] = std::nanf("");
  texsynth::save_histogram_transform(broken, stem);
  expect_recomputed("NaN in the LUT");
  broken = fresh;
  broken.gaussian[9] = HUGE_VALF;
  texsynth::save_histogram_transform(broken, stem);
  expect_recomputed("inf in the Gaussian");
  broken = fresh;
  std::swap(broken.inverse_lut[4 * 10], broken.inverse_lut[4 * 200]);
  texsynth::save_histogram_transform(broken, stem);
  expect_recomputed("non-monotone LUT");
  broken = fresh;
  broken.gaussian[0] = 1.5f;
  texsynth::save_histogram_transform(broken, stem);
  expect_recomputed("Gaussian value out of [0, 1]");

  // Files from two different transforms (a fallback LUT next to a Gaussianized sample): stale.
  Image flat = image;
  for (size_t p = 0; p < size_t(flat.pixel_count()); ++p) flat.pixels[p * 4] = 0.5f;
  const HistogramTransform other = texsynth::gaussianize(flat, 256);
  texsynth::save_histogram_transform(other, dir.file("other"));
  std::filesystem::copy_file(dir.file("other.lut.exr"), lut, std::filesystem::copy_options::overwrite_existing);
  expect_recomputed("mismatched pair");
}

TEST(GaussianizeFiles, CachedTransformIsReusedWhileItFits) {
  texsynth_test::TempDir dir;
  const std::string cache = dir.file("nested/cache");
  Image image = quantised_image(80, 60, 4, 40);
  const uint64_t hash = texsynth::image_hash(image);
  const HistogramTransform first = texsynth::histogram_transform_cached(image, hash, cache, 1024, 16);
  expect_same(first, texsynth::gaussianize(image, 1024, 16));
  const std::string stem = texsynth::histogram_file_stem(cache, hash, 1024);
  const auto written = std::filesystem::last_write_time(texsynth::histogram_gaussian_path(stem));
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  expect_same(texsynth::histogram_transform_cached(image, hash, cache, 1024, 16), first);
  EXPECT_EQ(std::filesystem::last_write_time(texsynth::histogram_gaussian_path(stem)), written) << "rewritten";

  // Another threshold decides differently: recomputed and rewritten.
  Image two_tone = image;
  for (size_t p = 0; p < size_t(two_tone.pixel_count()); ++p) two_tone.pixels[p * 4 + 1] = float(p % 2);
  const uint64_t two_hash = texsynth::image_hash(two_tone);
  EXPECT_FALSE(texsynth::histogram_transform_cached(two_tone, two_hash, cache, 1024, 16).ok);
  const HistogramTransform relaxed = texsynth::histogram_transform_cached(two_tone, two_hash, cache, 1024, 2);
  EXPECT_TRUE(relaxed.ok);
  EXPECT_EQ(relaxed.min_distinct_values, 2);
  const auto reloaded = texsynth::load_histogram_transform(texsynth::histogram_file_stem(cache, two_hash, 1024), 80,
                                                           60, 4, 1024);
  ASSERT_TRUE(reloaded);
  EXPECT_TRUE(reloaded->ok);

  // Files filed under this hash but made from a sample with another alpha: recomputed.
  Image other_alpha = image;
  for (size_t p = 0; p < size_t(other_alpha.pixel_count()); ++p) other_alpha.pixels[p * 4 + 3] = 0.5f;
  const HistogramTransform redone = texsynth::histogram_transform_cached(other_alpha, hash, cache, 1024, 16);
  expect_same(redone, texsynth::gaussianize(other_alpha, 1024, 16));
}

}  // namespace
