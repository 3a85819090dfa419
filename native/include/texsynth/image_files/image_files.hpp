// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Sample image files through OpenImageIO: what the C++ tools and scripts outside Blender read and write.
// Kept out of texsynth_core so that the module Blender loads needs no image library (docs/dev/blender_org_packages.md).
#include <cstdint>
#include <string>

#include "texsynth/image/image.hpp"

namespace texsynth {

struct ImageInfo {
  int width = 0;
  int height = 0;
  int channels = 0;
  std::string format;     // file format as named by OpenImageIO, e.g. "png", "openexr"
  std::string data_type;  // stored sample type, e.g. "uint8", "uint16", "half", "float"
};

// Reads header only. Throws std::invalid_argument naming the path and problem.
ImageInfo read_image_info(const std::string& path);

// Decodes the first subimage of any OpenImageIO-readable file, with all its channels (up to 64;
// preprocessing accepts 1-4); 8/16-bit data normalised to [0, 1].
// Throws std::invalid_argument for missing/unreadable/zero-byte/corrupt files, directories,
// images over the size limit and NaN/Inf pixels or pixels beyond ±kMaxPixelMagnitude.
Image load_image(const std::string& path);

// Writes an 8-bit image (PNG/JPEG/TIFF...); throws std::runtime_error on failure.
void write_image_u8(const std::string& path, const uint8_t* pixels, int width, int height, int channels);

}  // namespace texsynth
