// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>
#include <OpenImageIO/imageio.h>

#include <cmath>
#include <fstream>
#include <limits>

#include "temp_dir.hpp"
#include "texsynth/image_files/image_files.hpp"

using texsynth::ColorEncoding;
using texsynth::Image;

namespace {

// Smooth test pattern in [0, 1]: channel c of pixel (x, y).
float pattern(int x, int y, int c) { return 0.5f + 0.4f * std::sin(0.3f * x + c) * std::cos(0.2f * y - c); }

void write_file(const std::string& path, int w, int h, int channels, OIIO::TypeDesc type) {
  std::vector<float> pixels(size_t(w) * h * channels);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < channels; ++c) pixels[(size_t(y) * w + x) * channels + c] = pattern(x, y, c);
  auto out = OIIO::ImageOutput::create(path);
  ASSERT_TRUE(out) << OIIO::geterror();
  OIIO::ImageSpec spec(w, h, channels, type);
  spec.attribute("oiio:UnassociatedAlpha", 1);  // store the pattern as given, not premultiplied
  ASSERT_TRUE(out->open(path, spec));
  ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, pixels.data()));
  ASSERT_TRUE(out->close());
}

struct FormatCase {
  const char* name;
  int channels;
  OIIO::TypeDesc type;
  float tolerance;
  ColorEncoding encoding;
};

class ImageFormats : public ::testing::TestWithParam<FormatCase> {};

TEST_P(ImageFormats, LoadsWithDecodedValuesAndEncoding) {
  const FormatCase& fc = GetParam();
  texsynth_test::TempDir dir;
  const std::string path = dir.file(fc.name);
  write_file(path, 21, 17, fc.channels, fc.type);
  const Image image = texsynth::load_image(path);
  ASSERT_EQ(image.width, 21);
  ASSERT_EQ(image.height, 17);
  ASSERT_EQ(image.channels, fc.channels);
  EXPECT_EQ(image.encoding, fc.encoding);
  double max_error = 0;
  for (int y = 0; y < 17; ++y)
    for (int x = 0; x < 21; ++x)
      for (int c = 0; c < fc.channels; ++c)
        max_error = std::max(max_error, double(std::fabs(image.pixels[(size_t(y) * 21 + x) * fc.channels + c] -
                                                         pattern(x, y, c))));
  EXPECT_LE(max_error, fc.tolerance) << fc.name;
  const texsynth::ImageInfo info = texsynth::read_image_info(path);
  EXPECT_EQ(info.width, 21);
  EXPECT_EQ(info.height, 17);
  EXPECT_EQ(info.channels, fc.channels);
}

INSTANTIATE_TEST_SUITE_P(
    AllFormats, ImageFormats,
    ::testing::Values(FormatCase{"rgb8.png", 3, OIIO::TypeDesc::UINT8, 0.5f / 255 + 1e-6f, ColorEncoding::kSrgb},
                      FormatCase{"rgba16.png", 4, OIIO::TypeDesc::UINT16, 0.5f / 65535 + 1e-6f, ColorEncoding::kSrgb},
                      FormatCase{"gray8.png", 1, OIIO::TypeDesc::UINT8, 0.5f / 255 + 1e-6f, ColorEncoding::kSrgb},
                      FormatCase{"ga8.png", 2, OIIO::TypeDesc::UINT8, 0.5f / 255 + 1e-6f, ColorEncoding::kSrgb},
                      FormatCase{"rgb.jpg", 3, OIIO::TypeDesc::UINT8, 0.06f, ColorEncoding::kSrgb},
                      FormatCase{"rgbf.tif", 3, OIIO::TypeDesc::FLOAT, 0.0f, ColorEncoding::kLinear},
                      FormatCase{"rgbah.exr", 4, OIIO::TypeDesc::HALF, 1e-3f, ColorEncoding::kLinear}),
    [](const ::testing::TestParamInfo<FormatCase>& info) {
      std::string name = info.param.name;
      for (char& ch : name)
        if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
      return name;
    });

void expect_invalid(const std::string& path, const std::string& fragment) {
  try {
    texsynth::load_image(path);
    FAIL() << "no error for " << path;
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

TEST(ImageLoad, RejectsBadFilesWithClearMessages) {
  texsynth_test::TempDir dir;
  expect_invalid(dir.file("missing.png"), "does not exist");
  expect_invalid(dir.path().string(), "directory");
  { std::ofstream(dir.file("empty.png")); }
  expect_invalid(dir.file("empty.png"), "empty");
  {
    std::ofstream junk(dir.file("junk.png"), std::ios::binary);
    for (int i = 0; i < 1000; ++i) junk.put(char(i * 37));
  }
  expect_invalid(dir.file("junk.png"), "junk.png");
  // A PNG cut in half: header fine, pixel data missing.
  write_file(dir.file("whole.png"), 64, 64, 3, OIIO::TypeDesc::UINT8);
  std::ifstream whole(dir.file("whole.png"), std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(whole)), std::istreambuf_iterator<char>());
  { std::ofstream(dir.file("cut.png"), std::ios::binary).write(bytes.data(), std::streamsize(bytes.size() / 2)); }
  EXPECT_THROW(texsynth::load_image(dir.file("cut.png")), std::invalid_argument);
}

TEST(ImageLoad, DecodesExtraChannelsButSamplesNeedOneToFour) {
  texsynth_test::TempDir dir;
  write_file(dir.file("five.exr"), 12, 12, 5, OIIO::TypeDesc::HALF);
  const Image image = texsynth::load_image(dir.file("five.exr"));
  EXPECT_EQ(image.channels, 5);
  try {
    texsynth::validate_image(image);
    FAIL() << "5-channel sample accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("5 channels"), std::string::npos) << e.what();
  }
}

TEST(ImageLoad, RejectsNonFinitePixelsInFiles) {
  texsynth_test::TempDir dir;
  std::vector<float> pixels(16 * 16 * 3, 0.5f);
  pixels[100] = std::numeric_limits<float>::quiet_NaN();
  auto out = OIIO::ImageOutput::create(dir.file("nan.exr"));
  ASSERT_TRUE(out->open(dir.file("nan.exr"), OIIO::ImageSpec(16, 16, 3, OIIO::TypeDesc::FLOAT)));
  ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, pixels.data()));
  out->close();
  expect_invalid(dir.file("nan.exr"), "NaN");
}

TEST(ImageFromPixels, ConvertsTypesAndRejectsBadInput) {
  const uint8_t u8[6] = {0, 51, 255, 255, 0, 102};
  Image a = texsynth::image_from_pixels(u8, texsynth::PixelType::kUint8, 2, 1, 3);
  EXPECT_EQ(a.encoding, ColorEncoding::kSrgb);
  EXPECT_FLOAT_EQ(a.pixels[1], 0.2f);
  const uint16_t u16[2] = {0, 65535};
  EXPECT_FLOAT_EQ(texsynth::image_from_pixels(u16, texsynth::PixelType::kUint16, 2, 1, 1).pixels[1], 1.0f);
  const uint16_t halves[2] = {0x3C00, 0xC000};  // 1.0, -2.0
  Image h = texsynth::image_from_pixels(halves, texsynth::PixelType::kFloat16, 1, 1, 2);
  EXPECT_EQ(h.encoding, ColorEncoding::kLinear);
  EXPECT_EQ(h.pixels[0], 1.0f);
  EXPECT_EQ(h.pixels[1], -2.0f);
  const float bad[3] = {0.1f, std::numeric_limits<float>::infinity(), 0.2f};
  EXPECT_THROW(texsynth::image_from_pixels(bad, texsynth::PixelType::kFloat32, 1, 1, 3), std::invalid_argument);
  EXPECT_THROW(texsynth::image_from_pixels(u8, texsynth::PixelType::kUint8, 0, 1, 3), std::invalid_argument);
  EXPECT_THROW(texsynth::image_from_pixels(u8, texsynth::PixelType::kUint8, 1, 1, 5), std::invalid_argument);
  EXPECT_THROW(texsynth::image_from_pixels(u8, texsynth::PixelType::kUint8, 8193, 8193, 3), std::invalid_argument);
}

TEST(ImageHash, SensitiveToPixelsAndShape) {
  std::vector<uint8_t> pixels(12 * 3, 7);
  const uint64_t base = texsynth::image_hash(texsynth::image_from_pixels(pixels.data(), texsynth::PixelType::kUint8, 4, 3, 3));
  EXPECT_EQ(base, texsynth::image_hash(texsynth::image_from_pixels(pixels.data(), texsynth::PixelType::kUint8, 4, 3, 3)));
  EXPECT_NE(base, texsynth::image_hash(texsynth::image_from_pixels(pixels.data(), texsynth::PixelType::kUint8, 3, 4, 3)));
  pixels[20] = 8;
  EXPECT_NE(base, texsynth::image_hash(texsynth::image_from_pixels(pixels.data(), texsynth::PixelType::kUint8, 4, 3, 3)));
}

TEST(FeatureColors, MatchPublishedLabValues) {
  // Reference CIE L*a*b* (D65) values: sRGB white, black, red; linear 18% grey -> L* 49.496.
  const float srgb[9] = {1, 1, 1, 0, 0, 0, 1, 0, 0};
  const auto lab = texsynth::to_feature_colors(texsynth::image_from_pixels(srgb, texsynth::PixelType::kFloat32, 3, 1, 3));
  // Float input is linear: white/black are the same either way, red too (1.0 -> 1.0).
  EXPECT_NEAR(lab[0], 100.0, 0.01);
  EXPECT_NEAR(lab[1], 0.0, 0.01);
  EXPECT_NEAR(lab[2], 0.0, 0.01);
  EXPECT_NEAR(lab[3], 0.0, 0.01);
  EXPECT_NEAR(lab[6], 53.24, 0.02);
  EXPECT_NEAR(lab[7], 80.09, 0.05);
  EXPECT_NEAR(lab[8], 67.20, 0.05);
  const float grey = 0.18f;
  EXPECT_NEAR(texsynth::to_feature_colors(texsynth::image_from_pixels(&grey, texsynth::PixelType::kFloat32, 1, 1, 1))[0],
              49.496, 0.01);
  // 8-bit 119 is sRGB-encoded ~0.1845 linear -> L* ~50.0 (would be ~75.9 if wrongly treated as linear).
  const uint8_t mid = 119;
  EXPECT_NEAR(texsynth::to_feature_colors(texsynth::image_from_pixels(&mid, texsynth::PixelType::kUint8, 1, 1, 1))[0],
              50.0, 0.3);
  // Alpha becomes a 0..100 feature channel.
  const uint8_t ga[2] = {255, 255};
  const auto with_alpha = texsynth::to_feature_colors(texsynth::image_from_pixels(ga, texsynth::PixelType::kUint8, 1, 1, 2));
  ASSERT_EQ(with_alpha.size(), 2u);
  EXPECT_NEAR(with_alpha[1], 100.0, 1e-4);
}

}  // namespace
