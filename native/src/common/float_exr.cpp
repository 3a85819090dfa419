// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/common/float_exr.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <numeric>
#include <stdexcept>

// The one translation unit holding tinyexr's implementation (zlib for ZIP, as Debian builds it).
#define TINYEXR_IMPLEMENTATION
#define TINYEXR_USE_MINIZ 0
#define TINYEXR_USE_THREAD 0  // callers already run in parallel
#define TINYEXR_USE_OPENMP 0
#include <zlib.h>
#include <tinyexr.h>

namespace texsynth {

namespace {

// Owns what tinyexr allocates, so every early return frees it. Freed after a failed parse too: tinyexr
// can fail after ConvertHeader filled the header's arrays, and leaves them there (LeakSanitizer found it).
struct HeaderGuard {
  EXRHeader header;
  HeaderGuard() { InitEXRHeader(&header); }
  ~HeaderGuard() { FreeEXRHeader(&header); }
};

struct ImageGuard {
  EXRImage image;
  bool loaded = false;
  ImageGuard() { InitEXRImage(&image); }
  ~ImageGuard() {
    if (loaded) FreeEXRImage(&image);
  }
};

std::string take_error(const char* error, int code) {
  std::string text = error ? error : "tinyexr error " + std::to_string(code);
  if (error) FreeEXRErrorMessage(error);
  return text;
}

// Indices of channel_names in name order: the order OpenEXR stores them in.
std::vector<size_t> sorted_order(const std::vector<std::string>& names) {
  std::vector<size_t> order(names.size());
  std::iota(order.begin(), order.end(), size_t(0));
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return names[a] < names[b]; });
  return order;
}

void copy_name(char (&target)[256], const std::string& name) {
  std::memset(target, 0, sizeof(target));
  std::memcpy(target, name.data(), std::min(name.size(), sizeof(target) - 1));
}

}  // namespace

void write_float_exr(const std::string& path, const std::vector<float>& data, int width, int height,
                     const std::vector<std::string>& channel_names, const FloatExrTags& tags) {
  const size_t channels = channel_names.size();
  const size_t pixels = size_t(std::max(width, 0)) * size_t(std::max(height, 0));
  if (width <= 0 || height <= 0 || channels == 0 || data.size() != pixels * channels)
    throw std::runtime_error("cannot write '" + path + "': " + std::to_string(data.size()) + " values for " +
                             std::to_string(width) + "x" + std::to_string(height) + "x" + std::to_string(channels));
  const std::vector<size_t> order = sorted_order(channel_names);
  std::vector<std::vector<float>> planes(channels, std::vector<float>(pixels));
  for (size_t p = 0; p < pixels; ++p)
    for (size_t c = 0; c < channels; ++c) planes[c][p] = data[p * channels + order[c]];

  std::vector<unsigned char*> plane_pointers(channels);
  std::vector<EXRChannelInfo> infos(channels);
  std::vector<int> types(channels, TINYEXR_PIXELTYPE_FLOAT);
  std::vector<int> requested(channels, TINYEXR_PIXELTYPE_FLOAT);
  for (size_t c = 0; c < channels; ++c) {
    plane_pointers[c] = reinterpret_cast<unsigned char*>(planes[c].data());
    std::memset(&infos[c], 0, sizeof(EXRChannelInfo));
    copy_name(infos[c].name, channel_names[order[c]]);
    infos[c].pixel_type = TINYEXR_PIXELTYPE_FLOAT;
    infos[c].x_sampling = 1;
    infos[c].y_sampling = 1;
  }

  // Attribute values: ints little-endian (x86-64), strings as their bytes.
  std::vector<std::vector<unsigned char>> values;
  std::vector<EXRAttribute> attributes;
  auto add = [&](const std::string& name, const char* type, const void* bytes, size_t size) {
    values.emplace_back(static_cast<const unsigned char*>(bytes), static_cast<const unsigned char*>(bytes) + size);
    EXRAttribute attribute;
    std::memset(&attribute, 0, sizeof(attribute));
    copy_name(attribute.name, name);
    copy_name(attribute.type, type);
    attribute.size = int(size);
    attributes.push_back(attribute);
  };
  for (const auto& [name, value] : tags.ints) {
    const int32_t stored = value;
    add(name, "int", &stored, sizeof(stored));
  }
  for (const auto& [name, value] : tags.strings)
    if (!value.empty()) add(name, "string", value.data(), value.size());
  for (size_t i = 0; i < attributes.size(); ++i) attributes[i].value = values[i].data();

  EXRHeader header;
  InitEXRHeader(&header);
  header.num_channels = int(channels);
  header.channels = infos.data();
  header.pixel_types = types.data();
  header.requested_pixel_types = requested.data();
  header.compression_type = TINYEXR_COMPRESSIONTYPE_ZIP;
  header.num_custom_attributes = int(attributes.size());
  header.custom_attributes = attributes.empty() ? nullptr : attributes.data();
  EXRImage image;
  InitEXRImage(&image);
  image.num_channels = int(channels);
  image.images = plane_pointers.data();
  image.width = width;
  image.height = height;
  const char* error = nullptr;
  const int code = SaveEXRImageToFile(&image, &header, path.c_str(), &error);
  if (code != TINYEXR_SUCCESS) throw std::runtime_error("cannot write '" + path + "': " + take_error(error, code));
}

std::optional<FloatExr> read_float_exr(const std::string& path, int width, int height,
                                       const std::vector<std::string>& channel_names) {
  EXRVersion version;
  if (ParseEXRVersionFromFile(&version, path.c_str()) != TINYEXR_SUCCESS) return std::nullopt;
  if (version.multipart || version.non_image || version.tiled) return std::nullopt;
  HeaderGuard header;
  const char* error = nullptr;
  const int parsed = ParseEXRHeaderFromFile(&header.header, &version, path.c_str(), &error);
  if (parsed != TINYEXR_SUCCESS) {
    take_error(error, parsed);
    return std::nullopt;
  }
  const EXRHeader& h = header.header;
  const size_t channels = channel_names.size();
  // The layout is checked before any pixel is decoded: a damaged header cannot ask for memory.
  if (h.data_window.min_x != 0 || h.data_window.min_y != 0 || h.data_window.max_x != width - 1 ||
      h.data_window.max_y != height - 1 || h.num_channels != int(channels) || h.tiled)
    return std::nullopt;
  std::vector<int> target(channels, -1);  // file channel -> index in channel_names
  for (size_t c = 0; c < channels; ++c) {
    const EXRChannelInfo& info = h.channels[c];
    if (info.pixel_type != TINYEXR_PIXELTYPE_FLOAT || info.x_sampling != 1 || info.y_sampling != 1)
      return std::nullopt;
    const auto found = std::find(channel_names.begin(), channel_names.end(), std::string(info.name));
    if (found == channel_names.end()) return std::nullopt;
    target[c] = int(found - channel_names.begin());
  }
  std::vector<int> seen(target);
  std::sort(seen.begin(), seen.end());
  if (std::adjacent_find(seen.begin(), seen.end()) != seen.end()) return std::nullopt;  // a name twice

  FloatExr result;
  for (int a = 0; a < h.num_custom_attributes; ++a) {
    const EXRAttribute& attribute = h.custom_attributes[a];
    if (attribute.value == nullptr || attribute.size < 0) continue;
    const std::string type(attribute.type);
    if (type == "int" && attribute.size == 4) {
      int32_t value;
      std::memcpy(&value, attribute.value, 4);
      result.tags.ints[attribute.name] = value;
    } else if (type == "string") {
      result.tags.strings[attribute.name] =
          std::string(reinterpret_cast<const char*>(attribute.value), size_t(attribute.size));
    }
  }

  ImageGuard image;
  const int loaded = LoadEXRImageFromFile(&image.image, &h, path.c_str(), &error);
  if (loaded != TINYEXR_SUCCESS) {
    take_error(error, loaded);
    return std::nullopt;
  }
  image.loaded = true;
  if (image.image.width != width || image.image.height != height || image.image.images == nullptr)
    return std::nullopt;
  const size_t pixels = size_t(width) * size_t(height);
  result.data.resize(pixels * channels);
  for (size_t c = 0; c < channels; ++c) {
    const auto* plane = reinterpret_cast<const float*>(image.image.images[c]);
    if (plane == nullptr) return std::nullopt;
    for (size_t p = 0; p < pixels; ++p) result.data[p * channels + size_t(target[c])] = plane[p];
  }
  for (float value : result.data)
    if (!std::isfinite(value)) return std::nullopt;
  return result;
}

}  // namespace texsynth
