// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Sample images as TexSynth sees them. No file formats here: pixels come in as arrays (Blender decodes
// the sample inside Blender); files are read and written by image_files/ (OpenImageIO), outside Blender.
//
// Pixels are stored as float, row 0 = top, interleaved channels (1 gray, 2 gray+alpha, 3 RGB, 4 RGBA).
// Values are "as decoded": 8/16-bit integer data is normalised to [0, 1] and is taken to be
// sRGB-encoded; half/float data is taken to be linear (scene-referred) RGB with sRGB/Rec.709 primaries.
//
// Feature colour space: CIE L*a*b* (D65). Preprocessing compares neighbourhoods in L*a*b* because it is
// roughly perceptually uniform; linear radiance would let bright pixels dominate every distance.
// Alpha (when present) is appended as an extra feature channel scaled to 0..100 like L*.
#include <cstdint>
#include <string>
#include <vector>

namespace texsynth {

// Largest sample analysed at its own resolution (pixels). Analysis keeps ~100 bytes per pixel in
// flight, so a 4096 x 4096 sample already needs ~1.7 GB; larger ones are refused with a clear error.
constexpr int64_t kMaxImagePixels = int64_t(4096) * 4096;
// Largest sample decoded at all (8192²: 1 GB as RGBA floats). Only preprocessing through a working
// size takes more than kMaxImagePixels; everything else still refuses it.
constexpr int64_t kMaxSamplePixels = int64_t(8192) * 8192;
constexpr int kMaxImageSide = 65536;
// Largest pixel magnitude accepted (float images): beyond it the L*a*b* conversion overflows to
// NaN (fuzz_params found -2e36 turning textons into NaN). Real HDR radiance stays far below.
constexpr float kMaxPixelMagnitude = 1e9f;

enum class ColorEncoding { kSrgb, kLinear };

struct Image {
  int width = 0;
  int height = 0;
  int channels = 0;
  ColorEncoding encoding = ColorEncoding::kSrgb;
  std::vector<float> pixels;  // width*height*channels, row 0 = top

  int64_t pixel_count() const { return int64_t(width) * height; }
};

enum class PixelType { kUint8, kUint16, kFloat16, kFloat32 };

// Builds an Image from raw interleaved pixels (row 0 = top). Integer types are normalised to [0, 1]
// and marked sRGB; float types are kept as is and marked linear. Validates size, channels, NaN/Inf.
Image image_from_pixels(const void* data, PixelType type, int width, int height, int channels);

// Throws std::invalid_argument when dims/channels/size/pixel values are unusable (more than
// max_pixels pixels included).
void validate_image(const Image& image, int64_t max_pixels = kMaxImagePixels);

// The checks every decoder shares (pixel arrays here, files in image_files/), messages prefixed by `where`:
// size and channel count, then every value finite and within ±kMaxPixelMagnitude.
void check_image_dims(int width, int height, int channels, const std::string& where, int max_channels = 4,
                      int64_t max_pixels = kMaxSamplePixels);
void check_image_values(const std::vector<float>& pixels, int width, int channels, const std::string& where);

// 64-bit hash of the decoded pixels, dimensions, channel count and encoding.
uint64_t image_hash(const Image& image);

// Per-pixel feature channels in L*a*b* (+ alpha): returns width*height*feature_channel_count(image) floats.
int feature_channel_count(const Image& image);
std::vector<float> to_feature_colors(const Image& image);

}  // namespace texsynth
