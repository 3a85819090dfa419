// SPDX-License-Identifier: GPL-3.0-or-later
// The loader picks OpenImageIO's reader from the file's leading bytes and never lets it probe every
// plugin: damaged files in formats TexSynth does not take (GIF: fuzz_image found OpenImageIO's GIF
// reader calling std::terminate) must end in a clear error, never reach those readers. Headers that
// would make a reader allocate far more than the file holds (an OpenEXR attribute declaring 1.2 GB in
// a 130-byte file) are refused before the reader opens them.
#include <gtest/gtest.h>
#include <OpenImageIO/imageio.h>

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "temp_dir.hpp"
#include "texsynth/image_files/image_files.hpp"

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

// OpenEXR headers written byte by byte: attributes are "name\0type\0" + int32 size + value.
std::string le32(int64_t value) {
  std::string out;
  for (int i = 0; i < 4; ++i) out.push_back(char((uint64_t(value) >> (8 * i)) & 0xFF));
  return out;
}

std::string exr_attribute(const std::string& name, const std::string& type, const std::string& value) {
  return name + '\0' + type + '\0' + le32(int64_t(value.size())) + value;
}

float exr_value(int x, int y, int c) { return 0.125f * float(1 + c + 3 * (x + 2 * y)); }

// The attributes every OpenEXR image needs: float channels B, G, R (or c00, c01, ... when `channels`
// is not 3), uncompressed unless `compression` says otherwise (9: DWAB, 256 lines per chunk).
std::string exr_required_attributes(int width = 2, int height = 2, int channels = 3, int compression = 0) {
  std::string list;
  for (int c = 0; c < channels; ++c) {
    const std::string name = channels == 3 ? std::string(1, "BGR"[c]) : (c < 10 ? "c0" : "c") + std::to_string(c);
    list += name + '\0' + le32(2) + std::string(4, '\0') + le32(1) + le32(1);
  }
  const std::string box = le32(0) + le32(0) + le32(width - 1) + le32(height - 1);
  float one = 1.0f;
  const std::string one_bytes(reinterpret_cast<const char*>(&one), 4);
  return exr_attribute("channels", "chlist", list + '\0') +
         exr_attribute("compression", "compression", std::string(1, char(compression))) +
         exr_attribute("dataWindow", "box2i", box) + exr_attribute("displayWindow", "box2i", box) +
         exr_attribute("lineOrder", "lineOrder", std::string(1, '\0')) +
         exr_attribute("pixelAspectRatio", "float", one_bytes) +
         exr_attribute("screenWindowCenter", "v2f", std::string(8, '\0')) +
         exr_attribute("screenWindowWidth", "float", one_bytes);
}

// A complete single-part 2x2 scanline file: header (+ `extra` attributes), offset table, two chunks.
std::string exr_file(const std::string& extra) {
  std::string out = std::string("\x76\x2F\x31\x01", 4) + le32(2) + exr_required_attributes() + extra + '\0';
  const uint64_t first_chunk = out.size() + 16, chunk_bytes = 8 + 3 * 2 * 4;
  for (uint64_t chunk = 0; chunk < 2; ++chunk) {
    const uint64_t offset = first_chunk + chunk * chunk_bytes;
    for (int i = 0; i < 8; ++i) out.push_back(char((offset >> (8 * i)) & 0xFF));
  }
  for (int y = 0; y < 2; ++y) {
    out += le32(y) + le32(3 * 2 * 4);
    for (int c : {2, 1, 0})  // channels in the file's (alphabetical) order: B, G, R
      for (int x = 0; x < 2; ++x) {
        const float v = exr_value(x, y, c);
        out.append(reinterpret_cast<const char*>(&v), 4);
      }
  }
  return out;
}

// Overwrites the size field of attribute `name`; returns the position right after it.
size_t set_declared_size(std::string& file, const std::string& name, const std::string& type, int64_t size) {
  const size_t at = file.find(name + '\0' + type + '\0');
  EXPECT_NE(at, std::string::npos) << name;
  const size_t field = at + name.size() + type.size() + 2;
  file.replace(field, 4, le32(size));
  return field + 4;
}

TEST(ImageSniffing, HandMadeExrWithASmallAttributeLoads) {
  TempDir dir;
  write_bytes(dir.file("ok.exr"), exr_file(exr_attribute("owner", "string", "TexSynth test")));
  const texsynth::Image image = texsynth::load_image(dir.file("ok.exr"));
  ASSERT_EQ(image.width, 2);
  ASSERT_EQ(image.height, 2);
  ASSERT_EQ(image.channels, 3);
  EXPECT_EQ(image.encoding, texsynth::ColorEncoding::kLinear);
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 2; ++x)
      for (int c = 0; c < 3; ++c) EXPECT_EQ(image.pixels[size_t((y * 2 + x) * 3 + c)], exr_value(x, y, c));
  EXPECT_EQ(texsynth::read_image_info(dir.file("ok.exr")).format, "openexr");
}

TEST(ImageSniffing, ExrAttributeLargerThanTheRestOfTheFileIsRefused) {
  TempDir dir;
  const std::string valid = exr_file(exr_attribute("owner", "string", "TexSynth test"));
  const std::string path = dir.file("bad.exr");
  // One byte more than the file holds after the size field, the largest int32, a negative size.
  std::string file = valid;
  const size_t value_at = set_declared_size(file, "owner", "string", 0);
  for (int64_t size : {int64_t(valid.size() - value_at + 1), int64_t(0x7FFFFFFF), int64_t(-5)}) {
    file = valid;
    set_declared_size(file, "owner", "string", size);
    write_bytes(path, file);
    const std::string error = error_of(path);
    EXPECT_NE(error.find("image '" + path + "'"), std::string::npos) << error;
    EXPECT_NE(error.find("OpenEXR header attribute 'owner' (string) declares"), std::string::npos) << error;
    EXPECT_NE(error.find(size < 0 ? "negative size (-5)" : std::to_string(size) + " bytes but only " +
                                                                   std::to_string(valid.size() - value_at) + " bytes follow"),
              std::string::npos)
        << error;
    EXPECT_THROW(texsynth::read_image_info(path), std::invalid_argument);
  }
  // Declaring exactly what follows passes the walk; OpenEXR then finds the rest of the header missing.
  file = valid;
  set_declared_size(file, "owner", "string", int64_t(valid.size() - value_at));
  write_bytes(path, file);
  const std::string error = error_of(path);
  EXPECT_NE(error, "");
  EXPECT_EQ(error.find("declares"), std::string::npos) << error;
}

TEST(ImageSniffing, TruncatedExrHeadersAreClearErrors) {
  TempDir dir;
  const std::string valid = exr_file(exr_attribute("owner", "string", "TexSynth test"));
  const size_t header_end = valid.find(std::string("TexSynth test") + '\0') + 14;
  // Cut at every byte of the header: inside names (OpenEXR's error) or inside values (the walk's).
  for (size_t length = 4; length < header_end; ++length) {
    const std::string path = dir.file("cut.exr");
    write_bytes(path, valid.substr(0, length));
    const std::string error = error_of(path);
    EXPECT_NE(error, "") << length;
    if (length == header_end - 2)  // inside the last value: 12 of its 13 bytes
      EXPECT_NE(error.find("attribute 'owner' (string) declares 13 bytes but only 12 bytes follow"), std::string::npos)
          << error;
  }
}

TEST(ImageSniffing, ExrHeadersDeclaringMoreThan64MbInAllAreRefused) {
  // Two 40 MB attributes that the (sparse) file does hold: each fits, together they pass the cap.
  TempDir dir;
  const std::string path = dir.file("big.exr");
  const int64_t mb40 = int64_t(40) << 20;
  std::string head = std::string("\x76\x2F\x31\x01", 4) + le32(2) + exr_required_attributes() + "a" + '\0' + "blob" + '\0' + le32(mb40);
  write_bytes(path, head);
  const std::string second = std::string("b") + '\0' + "blob" + '\0' + le32(mb40);
  {
    std::fstream out(path, std::ios::binary | std::ios::in | std::ios::out);
    out.seekp(std::streamoff(head.size() + size_t(mb40)));
    out.write(second.data(), std::streamsize(second.size()));
  }
  std::filesystem::resize_file(path, head.size() + size_t(mb40) + second.size() + size_t(mb40) + 1);
  const std::string error = error_of(path);
  EXPECT_NE(error.find("OpenEXR header declares more than 64 MB of attributes (at attribute 'b'"), std::string::npos)
      << error;
}

TEST(ImageSniffing, EveryPartOfAMultiPartExrIsWalked) {
  TempDir dir;
  const std::string part = exr_required_attributes() + exr_attribute("type", "string", "scanlineimage") +
                           exr_attribute("chunkCount", "int", le32(2));
  std::string file = std::string("\x76\x2F\x31\x01", 4) + le32(2 | 0x1000) + part + exr_attribute("name", "string", "one") +
                     '\0' + part + exr_attribute("name", "string", "two") + exr_attribute("note", "string", "x") + '\0' +
                     '\0' + std::string(64, '\0');
  set_declared_size(file, "note", "string", 1 << 30);
  write_bytes(dir.file("parts.exr"), file);
  EXPECT_NE(error_of(dir.file("parts.exr")).find("attribute 'note' (string) declares 1073741824 bytes"), std::string::npos)
      << error_of(dir.file("parts.exr"));
  // Attribute names from the file reach the message printable only (it must stay valid UTF-8).
  file = exr_file(exr_attribute("caf\xC3\xA9\x01", "string", "x"));
  set_declared_size(file, "caf\xC3\xA9\x01", "string", 1 << 30);
  write_bytes(dir.file("name.exr"), file);
  EXPECT_NE(error_of(dir.file("name.exr")).find("attribute 'caf\?\?\?' (string)"), std::string::npos)
      << error_of(dir.file("name.exr"));
}

TEST(ImageSniffing, ExrWrittenByOpenImageIOWithMetadataAndTwoPartsLoads) {
  TempDir dir;
  std::vector<float> pixels(4 * 3 * 3);
  for (size_t i = 0; i < pixels.size(); ++i) pixels[i] = 0.01f * float(i);
  OIIO::ImageSpec spec(4, 3, 3, OIIO::TypeDesc::FLOAT);
  spec.attribute("ImageDescription", std::string(5000, 'd'));
  spec.attribute("compression", "zip");
  // Parts of one file share their display window: the second is 4x3 too, one half channel.
  const OIIO::ImageSpec specs[2] = {spec, OIIO::ImageSpec(4, 3, 1, OIIO::TypeDesc::HALF)};
  const std::vector<float> second(4 * 3, 0.5f);
  for (int parts : {1, 2}) {
    const std::string path = dir.file("oiio" + std::to_string(parts) + ".exr");
    auto out = OIIO::ImageOutput::create(path);
    ASSERT_TRUE(out);
    ASSERT_TRUE(out->open(path, parts, specs)) << out->geterror();
    ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, pixels.data()));
    if (parts == 2) {
      ASSERT_TRUE(out->open(path, specs[1], OIIO::ImageOutput::AppendSubimage)) << out->geterror();
      ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, second.data()));
    }
    ASSERT_TRUE(out->close());
    std::ifstream written(path, std::ios::binary);
    char start[8] = {};
    written.read(start, 8);
    EXPECT_EQ((start[5] & 0x10) != 0, parts == 2) << "multi-part flag (version field bit 12)";
    const texsynth::Image image = texsynth::load_image(path);
    ASSERT_EQ(image.pixels.size(), pixels.size()) << path;
    EXPECT_EQ(image.pixels, pixels) << path;
  }
}

// Peak RSS growth (MB), seconds and error text of load_image(path), run in a child process: the child's
// peak starts at its size at fork, so what the load allocates shows however large the parent ever was.
struct ChildLoad {
  double rss_growth_mb = -1, seconds = -1;
  std::string error;
};

ChildLoad load_in_child(const std::string& path) {
  int fds[2];
  if (pipe(fds) != 0) return {};
  const pid_t pid = fork();
  if (pid == 0) {
    close(fds[0]);
    rusage before{}, after{};
    getrusage(RUSAGE_SELF, &before);
    const auto start = std::chrono::steady_clock::now();
    const std::string error = error_of(path);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    getrusage(RUSAGE_SELF, &after);
    const std::string report = std::to_string(double(after.ru_maxrss - before.ru_maxrss) / 1024.0) + " " +
                               std::to_string(seconds) + " " + error;
    [[maybe_unused]] const ssize_t n = write(fds[1], report.data(), report.size());
    _exit(0);  // no atexit handlers (nor leak checks) of the parent's state in the child
  }
  close(fds[1]);
  std::string report;
  char buffer[4096];
  for (ssize_t n; (n = read(fds[0], buffer, sizeof(buffer))) > 0;) report.append(buffer, size_t(n));
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  ChildLoad result;
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) return result;
  std::istringstream fields(report);
  fields >> result.rss_growth_mb >> result.seconds;
  std::getline(fields >> std::ws, result.error);
  return result;
}

TEST(ImageSniffing, ExrHeaderDeclaringGigabytesIsRefusedBeforeOpenExrAllocatesIt) {
  // The fuzz_image reproducer (first byte chose the extension): a 130-byte OpenEXR header whose
  // 'Exif:ImageHistory' string declares 1,229,521,779 bytes, which OpenEXR allocated and cleared.
  std::ifstream in(std::string(TEXSYNTH_SOURCE_DIR) +
                       "/cpp_tests/fuzz/regressions/fuzz_image/exr_attribute_declares_1_2gb_timeout",
                   std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_EQ(bytes.size(), 130u);
  TempDir dir;
  for (const char* name : {"finding.exr", "finding.png"}) {
    write_bytes(dir.file(name), bytes.substr(1));
    const ChildLoad load = load_in_child(dir.file(name));
    ASSERT_GE(load.rss_growth_mb, 0) << "the child process did not report";
    EXPECT_NE(load.error.find("image '" + dir.file(name) + "': OpenEXR header attribute 'Exif:ImageHistory' (string) "
                              "declares 1229521779 bytes but only 92 bytes follow in the file"),
              std::string::npos)
        << load.error;
    // Memory is the bound the gate holds (time is reported, not asserted: a loaded machine is slow).
    EXPECT_LT(load.rss_growth_mb, 200.0);
    std::printf("[ measured ] %s refused in %.4f s, peak RSS growth %.1f MB\n", name, load.seconds, load.rss_growth_mb);
  }
}


TEST(ImageSniffing, ExrDeclaringMoreFloatsThanTheLargestRgbaSampleIsRefusedBeforeDecoding) {
  // Headers only, chunk offsets zero: 8192x8192 with 64 channels made load_image ask for 17 GB of
  // floats before OpenEXR found the pixels missing (std::bad_alloc, or all of the machine's memory).
  TempDir dir;
  for (const auto& [side, channels, need] : std::vector<std::tuple<int, int, std::string>>{
           {8192, 64, "8192x8192 with 64 channels needs 17.18 GB"}, {4096, 17, "4096x4096 with 17 channels needs 1.14 GB"}}) {
    const std::string path = dir.file("c" + std::to_string(channels) + ".exr");
    write_bytes(path, std::string("\x76\x2F\x31\x01", 4) + le32(2) + exr_required_attributes(side, side, channels, 9) +
                          '\0' + std::string(size_t((side + 255) / 256) * 8, '\0'));
    // OpenImageIO 2.4 (Debian 12) opens the header and leaves the size to load_image's own bound.
    // OpenImageIO 2.5 (Debian 13) refuses at open ("openexr header claims a 16384 MB image from a
    // 1795 byte file"). Either refusal is clear and allocates nothing; the pixels are never decoded.
    std::string open_error;
    try {
      EXPECT_EQ(texsynth::read_image_info(path).channels, channels);
    } catch (const std::exception& e) {
      open_error = e.what();
    }
    const ChildLoad load = load_in_child(path);
    ASSERT_GE(load.rss_growth_mb, 0) << "the child process did not report";
    if (open_error.empty()) {
      EXPECT_NE(load.error.find("image '" + path + "': " + need + " as floats, more than the 1.07 GB limit (8192x8192 RGBA)"),
                std::string::npos)
          << load.error;
    } else {
      EXPECT_NE(open_error.find("image '" + path + "': not a readable image (corrupt or unsupported format): "),
                std::string::npos)
          << open_error;
      EXPECT_EQ(load.error, open_error);
    }
    EXPECT_LT(load.rss_growth_mb, 200.0);
    std::printf("[ measured ] %dx%dx%d refused in %.4f s, peak RSS growth %.1f MB\n", side, side, channels,
                load.seconds, load.rss_growth_mb);
  }
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
