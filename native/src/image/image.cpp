// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/image/image.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include "texsynth/common/hash.hpp"

namespace texsynth {

namespace {

float srgb_to_linear(float v) {
  return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
}

float lab_f(float t) {
  constexpr float kDelta = 6.0f / 29.0f;
  return t > kDelta * kDelta * kDelta ? std::cbrt(t) : t / (3 * kDelta * kDelta) + 4.0f / 29.0f;
}

float half_to_float(uint16_t h) {
  const uint32_t sign = uint32_t(h & 0x8000u) << 16;
  const uint32_t exponent = (h >> 10) & 0x1Fu;
  const uint32_t mantissa = h & 0x3FFu;
  uint32_t bits;
  if (exponent == 0) {
    if (mantissa == 0) {
      bits = sign;
    } else {  // subnormal
      float v = std::ldexp(float(mantissa), -24);
      return (h & 0x8000u) ? -v : v;
    }
  } else if (exponent == 31) {
    bits = sign | 0x7F800000u | (mantissa << 13);
  } else {
    bits = sign | ((exponent + 112) << 23) | (mantissa << 13);
  }
  float f;
  std::memcpy(&f, &bits, 4);
  return f;
}

}  // namespace

void check_image_dims(int width, int height, int channels, const std::string& where, int max_channels,
                      int64_t max_pixels) {
  if (width <= 0 || height <= 0)
    throw std::invalid_argument(where + ": image has no pixels (" + std::to_string(width) + "x" +
                                std::to_string(height) + ")");
  if (width > kMaxImageSide || height > kMaxImageSide || int64_t(width) * height > max_pixels) {
    const int side = int(std::lround(std::sqrt(double(max_pixels))));
    const double gb = double(width) * double(height) * std::max(channels, 1) * sizeof(float) / 1e9;
    char need[32];
    std::snprintf(need, sizeof(need), "%.1f", gb);
    throw std::invalid_argument(where + ": image " + std::to_string(width) + "x" + std::to_string(height) +
                                " exceeds the limit of " + std::to_string(max_pixels) + " pixels (" +
                                std::to_string(side) + "x" + std::to_string(side) + "; its pixels alone need " +
                                need + " GB); downscale the sample");
  }
  if (channels < 1 || channels > max_channels)
    throw std::invalid_argument(where + ": image has " + std::to_string(channels) +
                                " channels; samples need 1 (gray), 2 (gray+alpha), 3 (RGB) or 4 (RGBA)");
}

void check_image_values(const std::vector<float>& pixels, int width, int channels, const std::string& where) {
  for (size_t i = 0; i < pixels.size(); ++i) {
    if (!(std::fabs(pixels[i]) <= kMaxPixelMagnitude)) {
      const size_t pixel = i / size_t(channels);
      throw std::invalid_argument(where + ": pixel (x=" + std::to_string(pixel % size_t(width)) +
                                  ", y=" + std::to_string(pixel / size_t(width)) + ") is " +
                                  (std::isfinite(pixels[i]) ? "beyond ±1e9 (" + std::to_string(pixels[i]) + ")"
                                                            : std::string("NaN or infinite")));
    }
  }
}

Image image_from_pixels(const void* data, PixelType type, int width, int height, int channels) {
  check_image_dims(width, height, channels, "pixel array");
  if (data == nullptr) throw std::invalid_argument("pixel array: null data");
  Image image;
  image.width = width;
  image.height = height;
  image.channels = channels;
  const size_t count = size_t(width) * size_t(height) * size_t(channels);
  image.pixels.resize(count);
  switch (type) {
    case PixelType::kUint8: {
      const auto* src = static_cast<const uint8_t*>(data);
      for (size_t i = 0; i < count; ++i) image.pixels[i] = float(src[i]) * (1.0f / 255.0f);  // same rounding as OpenImageIO
      image.encoding = ColorEncoding::kSrgb;
      break;
    }
    case PixelType::kUint16: {
      const auto* src = static_cast<const uint16_t*>(data);
      for (size_t i = 0; i < count; ++i) image.pixels[i] = float(src[i]) * (1.0f / 65535.0f);
      image.encoding = ColorEncoding::kSrgb;
      break;
    }
    case PixelType::kFloat16: {
      const auto* src = static_cast<const uint16_t*>(data);
      for (size_t i = 0; i < count; ++i) image.pixels[i] = half_to_float(src[i]);
      image.encoding = ColorEncoding::kLinear;
      break;
    }
    case PixelType::kFloat32: {
      std::memcpy(image.pixels.data(), data, count * sizeof(float));
      image.encoding = ColorEncoding::kLinear;
      break;
    }
  }
  check_image_values(image.pixels, width, channels, "pixel array");
  return image;
}

void validate_image(const Image& image, int64_t max_pixels) {
  check_image_dims(image.width, image.height, image.channels, "image", 4, max_pixels);
  if (image.pixels.size() != size_t(image.pixel_count()) * size_t(image.channels))
    throw std::invalid_argument("image: pixel buffer size does not match width*height*channels");
  check_image_values(image.pixels, image.width, image.channels, "image");
}

uint64_t image_hash(const Image& image) {
  uint64_t h = hash_bytes(image.pixels.data(), image.pixels.size() * sizeof(float), 0x7465787379ull);
  h = hash_combine(h, uint64_t(image.width));
  h = hash_combine(h, uint64_t(image.height));
  h = hash_combine(h, uint64_t(image.channels));
  return hash_combine(h, image.encoding == ColorEncoding::kSrgb ? 1 : 2);
}

int feature_channel_count(const Image& image) {
  const bool has_alpha = image.channels == 2 || image.channels == 4;
  const bool has_color = image.channels >= 3;
  return (has_color ? 3 : 1) + (has_alpha ? 1 : 0);
}

std::vector<float> to_feature_colors(const Image& image) {
  const int c_in = image.channels;
  const int c_out = feature_channel_count(image);
  const bool has_color = c_in >= 3;
  const bool has_alpha = c_in == 2 || c_in == 4;
  const size_t n = size_t(image.pixel_count());
  std::vector<float> out(n * size_t(c_out));
  const bool srgb = image.encoding == ColorEncoding::kSrgb;
  auto linear = [srgb](float v) { return srgb ? srgb_to_linear(v) : v; };
  for (size_t p = 0; p < n; ++p) {
    const float* src = &image.pixels[p * size_t(c_in)];
    float* dst = &out[p * size_t(c_out)];
    if (has_color) {
      const float r = linear(src[0]), g = linear(src[1]), b = linear(src[2]);
      // Linear sRGB (Rec.709 primaries) -> XYZ, normalised by the D65 white point.
      const float x = (0.4124564f * r + 0.3575761f * g + 0.1804375f * b) / 0.95047f;
      const float y = 0.2126729f * r + 0.7151522f * g + 0.0721750f * b;
      const float z = (0.0193339f * r + 0.1191920f * g + 0.9503041f * b) / 1.08883f;
      const float fx = lab_f(x), fy = lab_f(y), fz = lab_f(z);
      dst[0] = 116.0f * fy - 16.0f;
      dst[1] = 500.0f * (fx - fy);
      dst[2] = 200.0f * (fy - fz);
    } else {
      dst[0] = 116.0f * lab_f(linear(src[0])) - 16.0f;
    }
    if (has_alpha) dst[c_out - 1] = 100.0f * src[c_in - 1];
  }
  return out;
}

}  // namespace texsynth
