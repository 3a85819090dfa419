// SPDX-License-Identifier: GPL-3.0-or-later
// The loader picks OpenImageIO's reader from the file's leading bytes and never lets it probe every
// plugin: damaged files in formats TexSynth does not take (GIF: fuzz_image found OpenImageIO's GIF
// reader calling std::terminate) must end in a clear error, never reach those readers.
#include <gtest/gtest.h>
#include <OpenImageIO/imageio.h>

#include <cstdint>
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

// A 1x1, 8-bit, uncompressed TIFF written byte by byte (not by OpenImageIO, whose reader is what the
// check protects): little- or big-endian, classic or BigTIFF, with the given PhotometricInterpretation.
std::string tiff_bytes(bool little, bool big_tiff, int photometric) {
  std::string out;
  auto put = [&](uint64_t value, int width) {
    for (int i = 0; i < width; ++i) out.push_back(char((value >> (8 * (little ? i : width - 1 - i))) & 0xFF));
  };
  const int channels = photometric == 5 ? 4 : 3;
  const std::vector<std::pair<int, uint64_t>> tags = {
      {256, 1}, {257, 1}, {258, 8}, {259, 1}, {262, uint64_t(photometric)}, {273, 0 /* patched */},
      {277, uint64_t(channels)}, {278, 1}, {279, uint64_t(channels)}};
  out += little ? "II" : "MM";
  const int count_width = big_tiff ? 8 : 2, value_width = big_tiff ? 8 : 4, entry = big_tiff ? 20 : 12;
  if (big_tiff) put(43, 2), put(8, 2), put(0, 2), put(16, 8);
  else put(42, 2), put(8, 4);
  const uint64_t ifd_end = out.size() + count_width + tags.size() * entry + value_width;
  put(tags.size(), count_width);
  for (const auto& [tag, value] : tags) {
    put(uint64_t(tag), 2);
    put(tag == 273 ? 4 : 3, 2);  // LONG for the strip offset, SHORT otherwise
    put(1, value_width);
    const uint64_t v = tag == 273 ? ifd_end : value;
    if (tag == 273) put(v, value_width);
    else put(v, 2), put(0, value_width - 2);  // a SHORT sits left-justified in the value field
  }
  put(0, value_width);  // no next IFD
  out += std::string(size_t(channels), '\x80');
  return out;
}

TEST(ImageSniffing, CmykTiffIsRefusedBeforeOpenImageIOOpensIt) {
  // OpenImageIO 3.1 on Debian sid aborts the process ("stack smashing detected") opening a CMYK TIFF.
  TempDir dir;
  for (bool little : {true, false})
    for (bool big_tiff : {false, true}) {
      const std::string name = std::string(little ? "le" : "be") + (big_tiff ? "_big" : "") + "_cmyk.tif";
      write_bytes(dir.file(name), tiff_bytes(little, big_tiff, 5));
      EXPECT_NE(error_of(dir.file(name)).find("CMYK TIFF samples are not supported"), std::string::npos) << name;
      EXPECT_THROW(texsynth::read_image_info(dir.file(name)), std::invalid_argument) << name;
    }
  // The same file as RGB is no CMYK: it reaches OpenImageIO and decodes.
  write_bytes(dir.file("rgb.tif"), tiff_bytes(true, false, 2));
  EXPECT_EQ(error_of(dir.file("rgb.tif")), "");
  EXPECT_EQ(texsynth::load_image(dir.file("rgb.tif")).channels, 3);
  // A header cut inside the first IFD cannot say; OpenImageIO reports the damage.
  write_bytes(dir.file("cut.tif"), tiff_bytes(true, false, 5).substr(0, 30));
  const std::string cut = error_of(dir.file("cut.tif"));
  EXPECT_NE(cut, "");
  EXPECT_EQ(cut.find("CMYK"), std::string::npos) << cut;
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
