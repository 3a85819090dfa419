// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/image_files/image_files.hpp"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <stdexcept>

namespace texsynth {
namespace fs = std::filesystem;

namespace {

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  throw std::invalid_argument("image '" + path + "': " + what);
}

// Checks what OpenImageIO reports vaguely (or not at all) before handing the path over.
void check_readable_file(const std::string& path) {
  std::error_code ec;
  if (path.empty()) throw std::invalid_argument("image path is empty");
  if (!fs::exists(path, ec)) fail(path, "file does not exist");
  if (fs::is_directory(path, ec)) fail(path, "is a directory, not an image file");
  if (!fs::is_regular_file(path, ec)) fail(path, "is not a regular file");
  const auto size = fs::file_size(path, ec);
  if (ec) fail(path, "cannot read file size (" + ec.message() + ")");
  if (size == 0) fail(path, "file is empty (0 bytes)");
  std::ifstream probe(path, std::ios::binary);
  if (!probe) fail(path, "file cannot be opened for reading (permissions?)");
}

// PhotometricInterpretation (tag 262) of a TIFF's first image, or -1 when the header cannot say
// (truncated, unusual layout): OpenImageIO then reads it and reports what is wrong.
int tiff_photometric(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  auto read = [&](uint64_t offset, void* out, size_t bytes) {
    in.clear();
    in.seekg(std::streamoff(offset));
    in.read(static_cast<char*>(out), std::streamsize(bytes));
    return size_t(in.gcount()) == bytes;
  };
  unsigned char header[16];
  if (!read(0, header, 8)) return -1;
  const bool little = header[0] == 'I';
  auto number = [&](const unsigned char* bytes, int width) {
    uint64_t value = 0;
    for (int i = 0; i < width; ++i) value |= uint64_t(bytes[little ? i : width - 1 - i]) << (8 * i);
    return value;
  };
  const bool big_tiff = number(header + 2, 2) == 43;
  uint64_t ifd = number(header + 4, 4);
  if (big_tiff) {
    if (!read(0, header, 16)) return -1;
    ifd = number(header + 8, 8);
  }
  const int count_width = big_tiff ? 8 : 2, entry_size = big_tiff ? 20 : 12;
  unsigned char count_bytes[8];
  if (!read(ifd, count_bytes, size_t(count_width))) return -1;
  // The whole directory in one read; a cut one is scanned as far as its complete entries go.
  std::vector<unsigned char> entries(size_t(std::min<uint64_t>(number(count_bytes, count_width), 4096)) * entry_size);
  read(ifd + uint64_t(count_width), entries.data(), entries.size());
  const size_t complete = size_t(in.gcount()) / size_t(entry_size);
  for (size_t e = 0; e < complete; ++e) {
    const unsigned char* entry = entries.data() + e * size_t(entry_size);
    if (number(entry, 2) == 262) return int(number(entry + (big_tiff ? 12 : 8), 2));  // SHORT value, left-justified
  }
  return -1;
}

// What an OpenEXR header may make OpenEXR allocate: each attribute's value is read into a buffer of
// the size the header declares, cleared first (fuzz_image: a 130-byte file whose string attribute
// declared 1.2 GB took 1.3 GB and seconds in Release, more than 10 s under ASan). A valid header holds
// a few kB; previews, ICC profiles and Cryptomatte manifests reach megabytes.
constexpr int64_t kMaxExrHeaderBytes = int64_t(64) << 20;

// Printable form of a name read from a file (the error text must stay valid UTF-8 for Python).
std::string printable(const std::string& raw) {
  std::string out;
  for (char c : raw.substr(0, 64)) out += (c >= 0x20 && c < 0x7F) ? c : '?';
  return raw.size() > 64 ? out + "..." : out;
}

// Walks an OpenEXR header (every part's, for multi-part files) before OpenEXR reads it: attributes
// are "name\0type\0" + int32 size (little-endian) + value. An attribute whose declared size does not
// fit in what follows in the file, or headers declaring more than kMaxExrHeaderBytes in all, are
// refused. Whatever the walk cannot parse (a cut or malformed name) is left to OpenEXR, which stops at
// the same place with its own error and before allocating anything for it.
void check_exr_header(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::error_code ec;
  const int64_t file_size = int64_t(fs::file_size(path, ec));
  if (ec || !in) return;
  unsigned char start[8];
  if (!in.read(reinterpret_cast<char*>(start), 8)) return;
  const bool multipart = (start[5] & 0x10) != 0;  // version field bit 12
  // One null-terminated name (OpenEXR allows 255 characters at most); false when the file cannot say.
  auto read_name = [&](std::string& name) {
    name.clear();
    for (int i = 0; i < 256; ++i) {
      const int c = in.get();
      if (c == std::char_traits<char>::eof()) return false;
      if (c == 0) return true;
      name.push_back(char(c));
    }
    return false;
  };
  int64_t declared = 0;
  std::string name, type;
  for (;;) {
    int attributes = 0;
    for (;; ++attributes) {
      if (!read_name(name)) return;
      if (name.empty()) break;  // end of this header
      unsigned char size_bytes[4];
      if (!read_name(type) || !in.read(reinterpret_cast<char*>(size_bytes), 4)) return;
      const int32_t size = int32_t(uint32_t(size_bytes[0]) | uint32_t(size_bytes[1]) << 8 |
                                   uint32_t(size_bytes[2]) << 16 | uint32_t(size_bytes[3]) << 24);
      const int64_t here = int64_t(in.tellg());
      if (here < 0) return;
      const std::string what = "OpenEXR header attribute '" + printable(name) + "' (" + printable(type) + ")";
      if (size < 0) fail(path, what + " declares a negative size (" + std::to_string(size) + "): corrupt file");
      if (size > file_size - here)
        fail(path, what + " declares " + std::to_string(size) + " bytes but only " + std::to_string(file_size - here) +
                       " bytes follow in the file: truncated or corrupt file");
      declared += size;
      if (declared > kMaxExrHeaderBytes)
        fail(path, "OpenEXR header declares more than " + std::to_string(kMaxExrHeaderBytes >> 20) +
                       " MB of attributes (at attribute '" + printable(name) + "', " + std::to_string(size) +
                       " bytes): corrupt file or not a texture sample");
      in.seekg(size, std::ios::cur);
    }
    // A multi-part file's headers end with an empty one (a lone null byte where a name would start).
    if (!multipart || attributes == 0) return;
  }
}

// The OpenImageIO reader for a sample file, chosen from its leading bytes (TGA, which has none, from
// its extension). OpenImageIO is never left to guess: its probe tries every plugin it has (GIF, PSD,
// DPX, FITS, camera RAW, DICOM, ...), and some abort the process on damaged files (fuzz_image found
// std::terminate inside the GIF reader), which inside Blender loses the artist's work.
std::string sniff_format(const std::string& path) {
  unsigned char head[12] = {0};
  std::ifstream in(path, std::ios::binary);
  in.read(reinterpret_cast<char*>(head), sizeof(head));
  const size_t n = size_t(in.gcount());
  auto starts = [&](const char* magic, size_t length) { return n >= length && std::memcmp(head, magic, length) == 0; };
  if (starts("\x89PNG\r\n\x1a\n", 8)) return "png";
  if (starts("\xFF\xD8\xFF", 3)) return "jpeg";
  if (starts("\x76\x2F\x31\x01", 4)) {
    check_exr_header(path);  // before OpenEXR allocates what the header declares
    return "openexr";
  }
  if (starts("II*\0", 4) || starts("MM\0*", 4) || starts("II+\0", 4) || starts("MM\0+", 4)) {
    // OpenImageIO 3.1 (Debian sid) smashes its stack opening a CMYK TIFF, which would kill Blender.
    if (tiff_photometric(path) == 5)
      fail(path, "CMYK TIFF samples are not supported (save the sample as RGB)");
    return "tiff";
  }
  if (starts("BM", 2)) return "bmp";
  if (starts("#?", 2)) return "hdr";  // Radiance "#?RADIANCE" / "#?RGBE"
  if (n >= 2 && head[0] == 'P' && std::strchr("123456fF", head[1]) && head[1] != 0) return "pnm";  // PBM..PPM, PFM
  if (starts("RIFF", 4) && n >= 12 && std::memcmp(head + 8, "WEBP", 4) == 0) return "webp";
  if (starts("GIF8", 4)) fail(path, "GIF samples are not supported (convert the image to PNG)");
  std::string ext = fs::path(path).extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  if (ext == ".tga" || ext == ".tpic") return "targa";
  fail(path, "not a supported image format (PNG, JPEG, OpenEXR, TIFF, BMP, Radiance HDR, PNM/PFM, WebP or TGA)");
}

std::unique_ptr<OIIO::ImageInput> open_input(const std::string& path) {
  check_readable_file(path);
  // Keep colour and alpha as stored (no premultiplication): features compare what the artist painted.
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);
  auto input = OIIO::ImageInput::create(sniff_format(path));
  OIIO::ImageSpec spec;
  if (!input || !input->open(path, spec, config)) {
    std::string err = input ? input->geterror() : OIIO::geterror();
    fail(path, "not a readable image (corrupt or unsupported format)" + (err.empty() ? "" : ": " + err));
  }
  return input;
}

constexpr int kMaxFileChannels = 64;
// Most floats one decoded file may take: the largest sample (kMaxSamplePixels) as RGBA.
constexpr int64_t kMaxDecodedValues = kMaxSamplePixels * 4;

std::string type_name(OIIO::TypeDesc t) {
  switch (t.basetype) {
    case OIIO::TypeDesc::UINT8: return "uint8";
    case OIIO::TypeDesc::INT8: return "int8";
    case OIIO::TypeDesc::UINT16: return "uint16";
    case OIIO::TypeDesc::INT16: return "int16";
    case OIIO::TypeDesc::HALF: return "half";
    case OIIO::TypeDesc::FLOAT: return "float";
    case OIIO::TypeDesc::DOUBLE: return "double";
    default: return t.c_str();
  }
}

// Integer-coded files are display-referred (sRGB); half/float files hold linear values.
ColorEncoding encoding_of(OIIO::TypeDesc t) {
  switch (t.basetype) {
    case OIIO::TypeDesc::HALF:
    case OIIO::TypeDesc::FLOAT:
    case OIIO::TypeDesc::DOUBLE: return ColorEncoding::kLinear;
    default: return ColorEncoding::kSrgb;
  }
}

}  // namespace

ImageInfo read_image_info(const std::string& path) {
  auto input = open_input(path);
  const OIIO::ImageSpec& spec = input->spec();
  // fuzz_image: a Radiance header "+X 0" opens as a 0-pixel-wide image.
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0)
    fail(path, "image has no pixels (" + std::to_string(spec.width) + "x" + std::to_string(spec.height) + ", " +
                   std::to_string(spec.nchannels) + " channels)");
  ImageInfo info;
  info.width = spec.width;
  info.height = spec.height;
  info.channels = spec.nchannels;
  info.format = input->format_name();
  info.data_type = type_name(spec.format);
  input->close();
  return info;
}

Image load_image(const std::string& path) {
  auto input = open_input(path);
  const OIIO::ImageSpec spec = input->spec();
  // Any channel count decodes; preprocessing (validate_image) then insists on 1-4.
  check_image_dims(spec.width, spec.height, spec.nchannels, "image '" + path + "'", kMaxFileChannels);
  if (spec.depth > 1) fail(path, "volume images are not supported");
  // The decoded floats are allocated (and cleared) before the reader finds out whether the file holds
  // them: a 1.8 kB OpenEXR header declaring 8192x8192 with 64 channels asked for 17 GB. Bounded at
  // what the largest sample takes as RGBA (8192x8192x4 floats, 1.07 GB); more channels, fewer pixels.
  const int64_t values = int64_t(spec.width) * spec.height * spec.nchannels;
  if (values > kMaxDecodedValues) {
    char need[32], limit[32];
    std::snprintf(need, sizeof(need), "%.2f", double(values) * sizeof(float) / 1e9);
    std::snprintf(limit, sizeof(limit), "%.2f", double(kMaxDecodedValues) * sizeof(float) / 1e9);
    fail(path, std::to_string(spec.width) + "x" + std::to_string(spec.height) + " with " +
                   std::to_string(spec.nchannels) + " channels needs " + need + " GB as floats, more than the " +
                   limit + " GB limit (8192x8192 RGBA); keep only the channels the sample needs, or downscale it");
  }
  Image image;
  image.width = spec.width;
  image.height = spec.height;
  image.channels = spec.nchannels;
  image.encoding = encoding_of(spec.format);
  image.pixels.resize(size_t(image.pixel_count()) * size_t(image.channels));
  if (!input->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, image.pixels.data())) {
    fail(path, "cannot decode pixels (truncated or corrupt file): " + input->geterror());
  }
  if (input->has_error()) fail(path, "decode error: " + input->geterror());
  input->close();
  check_image_values(image.pixels, image.width, image.channels, "image '" + path + "'");
  return image;
}

void write_image_u8(const std::string& path, const uint8_t* pixels, int width, int height, int channels) {
  auto out = OIIO::ImageOutput::create(path);
  if (!out) throw std::runtime_error("cannot write image '" + path + "': " + OIIO::geterror());
  OIIO::ImageSpec spec(width, height, channels, OIIO::TypeDesc::UINT8);
  if (!out->open(path, spec) || !out->write_image(OIIO::TypeDesc::UINT8, pixels) || !out->close())
    throw std::runtime_error("cannot write image '" + path + "': " + out->geterror());
}

}  // namespace texsynth
