// SPDX-License-Identifier: GPL-3.0-or-later
// The loader picks OpenImageIO's reader from the file's leading bytes and never lets it probe every
// plugin: damaged files in formats TexSynth does not take (GIF: fuzz_image found OpenImageIO's GIF
// reader calling std::terminate) must end in a clear error, never reach those readers.
#include <gtest/gtest.h>
#include <OpenImageIO/imageio.h>

#include <fstream>
#include <string>
#include <vector>

#include "temp_dir.hpp"
#include "texsynth/image/image.hpp"

namespace {

using texsynth_test::TempDir;

void write_bytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
}

std::string error_of(const std::string& path) {
  try {
    texsynth::load_image(path);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(ImageSniffing, DamagedGifThatCrashedOpenImageIOIsAClearError) {
  TempDir dir;
  // The fuzz_image reproducer (its first byte chose the extension): "GIF8" + an EXR-like header.
  std::ifstream in(std::string(TEXSYNTH_SOURCE_DIR) + "/cpp_tests/fuzz/regressions/fuzz_image/gif_reader_terminate",
                   std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_GT(bytes.size(), 16u);
  for (const char* name : {"crash.gif", "crash.png", "crash.exr", "crash"}) {
    write_bytes(dir.file(name), bytes.substr(1));
    EXPECT_NE(error_of(dir.file(name)).find("GIF samples are not supported"), std::string::npos) << name;
    EXPECT_THROW(texsynth::read_image_info(dir.file(name)), std::invalid_argument) << name;
  }
}

TEST(ImageSniffing, FormatsOutsideTheListAreRefusedWithTheList) {
  TempDir dir;
  for (const auto& [name, bytes] : std::vector<std::pair<std::string, std::string>>{
           {"layers.psd", "8BPS\x00\x01garbage"}, {"scan.dpx", "SDPXgarbagegarbage"}, {"x.fits", "SIMPLE  =    T"},
           {"notes.png", "just some text"}}) {
    write_bytes(dir.file(name), bytes);
    EXPECT_NE(error_of(dir.file(name)).find("not a supported image format"), std::string::npos) << name;
  }
}

TEST(ImageSniffing, ContentDecidesNotTheExtensionAndTgaGoesByExtension) {
  TempDir dir;
  const std::vector<unsigned char> pixels = {10, 20, 30, 40, 50, 60, 70, 80, 90, 100, 110, 120};
  for (const char* name : {"a.png", "a.tga", "a.bmp", "a.ppm"}) {
    auto out = OIIO::ImageOutput::create(dir.file(name));
    ASSERT_TRUE(out) << name;
    ASSERT_TRUE(out->open(dir.file(name), OIIO::ImageSpec(2, 2, 3, OIIO::TypeDesc::UINT8))) << name;
    ASSERT_TRUE(out->write_image(OIIO::TypeDesc::UINT8, pixels.data()));
    out->close();
    const texsynth::Image image = texsynth::load_image(dir.file(name));
    ASSERT_EQ(image.pixel_count(), 4) << name;
    EXPECT_NEAR(image.pixels[4], 50.f / 255.f, 1e-6f) << name;
  }
  // A PNG named .jpg still loads as the PNG it is.
  std::ifstream png(dir.file("a.png"), std::ios::binary);
  write_bytes(dir.file("renamed.jpg"), std::string((std::istreambuf_iterator<char>(png)), std::istreambuf_iterator<char>()));
  EXPECT_NEAR(texsynth::load_image(dir.file("renamed.jpg")).pixels[4], 50.f / 255.f, 1e-6f);
}

}  // namespace

namespace {

// fuzz_params: float pixels of -2e36 passed the NaN/Inf check and overflowed the L*a*b* conversion
// into NaN textons. fuzz_image: a Radiance header with "+X 0" opened as a 0-wide image.
TEST(ImageValues, HugeFloatPixelsAndZeroSizedHeadersAreClearErrors) {
  std::vector<float> pixels(4 * 4 * 3, 0.5f);
  EXPECT_NO_THROW(texsynth::image_from_pixels(pixels.data(), texsynth::PixelType::kFloat32, 4, 4, 3));
  pixels[7] = 1e9f;  // the largest accepted magnitude
  EXPECT_NO_THROW(texsynth::image_from_pixels(pixels.data(), texsynth::PixelType::kFloat32, 4, 4, 3));
  for (float bad : {-2.03762e36f, 1.01e9f, -1.01e9f}) {
    pixels[7] = bad;
    try {
      texsynth::image_from_pixels(pixels.data(), texsynth::PixelType::kFloat32, 4, 4, 3);
      ADD_FAILURE() << bad << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("pixel (x=2, y=0) is beyond"), std::string::npos) << e.what();
    }
  }
  TempDir dir;
  write_bytes(dir.file("zero.hdr"), "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 8 +X 0\n");
  EXPECT_THROW(texsynth::read_image_info(dir.file("zero.hdr")), std::invalid_argument);
  EXPECT_THROW(texsynth::load_image(dir.file("zero.hdr")), std::invalid_argument);
}

}  // namespace
