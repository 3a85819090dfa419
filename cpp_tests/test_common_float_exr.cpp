// SPDX-License-Identifier: GPL-3.0-or-later
// The cache's float EXR files through tinyexr (common/float_exr): round trips, files written by
// OpenImageIO (caches from before the split, and what Blender's shaders read), and damaged files.
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include "temp_dir.hpp"
#include "texsynth/common/float_exr.hpp"

namespace {

using texsynth::FloatExrTags;
using texsynth::read_float_exr;
using texsynth::write_float_exr;

std::vector<float> ramp(size_t count, float offset) {
  std::vector<float> values(count);
  for (size_t i = 0; i < count; ++i) values[i] = offset + 0.37f * float(i) - 1e-3f * float(i * i % 17);
  return values;
}

TEST(FloatExr, RoundTripKeepsEveryValueChannelOrderAndTag) {
  texsynth_test::TempDir dir;
  const std::vector<std::vector<std::string>> layouts = {{"Y"}, {"Y", "A"}, {"R", "G", "B"}, {"R", "G", "B", "A"}};
  for (const auto& names : layouts) {
    const int width = 7, height = 5;
    const std::vector<float> data = ramp(size_t(width * height) * names.size(), -3.0f);
    FloatExrTags tags;
    tags.ints = {{"texsynth:ok", 1}, {"texsynth:colour_channels", int(names.size())}, {"texsynth:negative", -42}};
    tags.strings = {{"texsynth:fallback_reason", "channel 0 has only 3 distinct values"}, {"texsynth:empty", ""}};
    const std::string path = dir.file("layout" + std::to_string(names.size()) + ".exr");
    write_float_exr(path, data, width, height, names, tags);
    const auto read = read_float_exr(path, width, height, names);
    ASSERT_TRUE(read.has_value()) << names.size();
    EXPECT_EQ(read->data, data) << names.size();
    EXPECT_EQ(read->tags.ints.at("texsynth:ok"), 1);
    EXPECT_EQ(read->tags.ints.at("texsynth:colour_channels"), int(names.size()));
    EXPECT_EQ(read->tags.ints.at("texsynth:negative"), -42);
    EXPECT_EQ(read->tags.strings.at("texsynth:fallback_reason"), "channel 0 has only 3 distinct values");
    EXPECT_EQ(read->tags.strings.count("texsynth:empty"), 0u) << "empty strings are not written";
  }
}

TEST(FloatExr, OpenImageIOReadsWhatTinyexrWroteChannelByName) {
  // Blender and the Python tests open these files with other readers: R must stay R.
  texsynth_test::TempDir dir;
  const int width = 3, height = 2;
  const std::vector<std::string> names = {"R", "G", "B", "A"};
  const std::vector<float> data = ramp(size_t(width * height) * 4, 0.5f);
  write_float_exr(dir.file("x.exr"), data, width, height, names, FloatExrTags{{{"texsynth:ok", 0}}, {}});
  auto in = OIIO::ImageInput::open(dir.file("x.exr"));
  ASSERT_TRUE(in);
  const OIIO::ImageSpec& spec = in->spec();
  ASSERT_EQ(spec.nchannels, 4);
  std::vector<float> pixels(data.size());
  ASSERT_TRUE(in->read_image(0, 0, 0, 4, OIIO::TypeDesc::FLOAT, pixels.data()));
  for (int c = 0; c < 4; ++c) {
    const int index = int(std::find(spec.channelnames.begin(), spec.channelnames.end(), names[size_t(c)]) -
                          spec.channelnames.begin());
    ASSERT_LT(index, 4) << names[size_t(c)];
    for (int p = 0; p < width * height; ++p) EXPECT_EQ(pixels[size_t(p * 4 + index)], data[size_t(p * 4 + c)]);
  }
  EXPECT_EQ(spec.get_int_attribute("texsynth:ok", -1), 0);
}

TEST(FloatExr, ReadsFilesWrittenByOpenImageIO) {
  // Caches written before the split were OpenImageIO's; they stay readable (or are recomputed, never wrong).
  texsynth_test::TempDir dir;
  const int width = 4, height = 3;
  const std::vector<float> data = ramp(size_t(width * height) * 3, 0.25f);
  OIIO::ImageSpec spec(width, height, 3, OIIO::TypeDesc::FLOAT);
  spec.channelnames = {"R", "G", "B"};
  spec.attribute("compression", "zip");
  spec.attribute("texsynth:histogram_version", 1);
  spec.attribute("texsynth:fallback_reason", "flat");
  auto out = OIIO::ImageOutput::create("openexr");
  ASSERT_TRUE(out && out->open(dir.file("oiio.exr"), spec));
  ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, data.data()) && out->close());
  const auto read = read_float_exr(dir.file("oiio.exr"), width, height, {"R", "G", "B"});
  ASSERT_TRUE(read.has_value());
  EXPECT_EQ(read->data, data);
  EXPECT_EQ(read->tags.ints.at("texsynth:histogram_version"), 1);
  EXPECT_EQ(read->tags.strings.at("texsynth:fallback_reason"), "flat");
}

TEST(FloatExr, AnotherLayoutOrADamagedFileIsNotRead) {
  texsynth_test::TempDir dir;
  const std::vector<float> data = ramp(6 * 4 * 3, 1.0f);
  const std::string path = dir.file("good.exr");
  write_float_exr(path, data, 6, 4, {"R", "G", "B"}, {});
  EXPECT_FALSE(read_float_exr(path, 6, 5, {"R", "G", "B"})) << "another height";
  EXPECT_FALSE(read_float_exr(path, 4, 6, {"R", "G", "B"})) << "width and height swapped";
  EXPECT_FALSE(read_float_exr(path, 6, 4, {"R", "G", "B", "A"})) << "another channel count";
  EXPECT_FALSE(read_float_exr(path, 6, 4, {"X", "G", "B"})) << "another channel name";
  EXPECT_FALSE(read_float_exr(dir.file("missing.exr"), 6, 4, {"R", "G", "B"}));
  std::ifstream in(path, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  // Every truncation: refused without a crash (ASan checks the reads in the sanitizer stage).
  for (size_t keep = 0; keep < bytes.size(); keep += std::max<size_t>(1, bytes.size() / 97)) {
    const std::string cut = dir.file("cut.exr");
    std::ofstream(cut, std::ios::binary | std::ios::trunc).write(bytes.data(), std::streamsize(keep));
    EXPECT_FALSE(read_float_exr(cut, 6, 4, {"R", "G", "B"})) << "kept " << keep << " of " << bytes.size();
  }
  // A NaN in the pixels: not a usable cache file.
  std::vector<float> with_nan = data;
  with_nan[7] = std::nanf("");
  write_float_exr(dir.file("nan.exr"), with_nan, 6, 4, {"R", "G", "B"}, {});
  EXPECT_FALSE(read_float_exr(dir.file("nan.exr"), 6, 4, {"R", "G", "B"}));
}

TEST(FloatExr, WritingAMismatchedBufferOrIntoAMissingFolderThrowsNamingThePath) {
  texsynth_test::TempDir dir;
  EXPECT_THROW(write_float_exr(dir.file("short.exr"), std::vector<float>(5), 2, 2, {"R", "G", "B"}, {}),
               std::runtime_error);
  try {
    write_float_exr(dir.file("no/such/folder/x.exr"), std::vector<float>(12), 2, 2, {"R", "G", "B"}, {});
    FAIL() << "expected a write error";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("no/such/folder/x.exr"), std::string::npos) << error.what();
  }
}

}  // namespace
