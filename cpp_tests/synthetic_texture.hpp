// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Texture-like synthetic samples for tests and benchmarks: jittered bricks with mortar, per-brick tint
// and value noise (sRGB-encoded RGB floats). Deterministic for a seed.
#include <cmath>

#include "texsynth/common/rng.hpp"
#include "texsynth/image/image.hpp"

namespace texsynth_test {

inline float lattice_noise(int x, int y, uint64_t seed) {
  return float(texsynth::splitmix64(seed ^ (uint64_t(uint32_t(x)) << 32 | uint32_t(y))) >> 40) / float(1 << 24);
}

// Bilinear value noise with the given cell size.
inline float value_noise(float x, float y, float cell, uint64_t seed) {
  const float gx = x / cell, gy = y / cell;
  const int ix = int(std::floor(gx)), iy = int(std::floor(gy));
  const float fx = gx - ix, fy = gy - iy;
  const float a = lattice_noise(ix, iy, seed), b = lattice_noise(ix + 1, iy, seed);
  const float c = lattice_noise(ix, iy + 1, seed), d = lattice_noise(ix + 1, iy + 1, seed);
  return (a * (1 - fx) + b * fx) * (1 - fy) + (c * (1 - fx) + d * fx) * fy;
}

inline texsynth::Image brick_texture(int width, int height, uint64_t seed = 1) {
  texsynth::Image image;
  image.width = width;
  image.height = height;
  image.channels = 3;
  image.encoding = texsynth::ColorEncoding::kSrgb;
  image.pixels.resize(size_t(width) * height * 3);
  const int brick_w = 48, brick_h = 20, mortar = 3;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const int row = y / brick_h;
      const int shifted = x + (row % 2) * brick_w / 2;
      const int col = shifted / brick_w;
      const bool in_mortar = (y % brick_h) < mortar || (shifted % brick_w) < mortar;
      const float grain = 0.6f * value_noise(float(x), float(y), 3.0f, seed) + 0.4f * value_noise(float(x), float(y), 11.0f, seed + 7);
      const float tint = lattice_noise(col, row, seed + 3);
      float rgb[3];
      if (in_mortar) {
        rgb[0] = rgb[1] = rgb[2] = 0.55f + 0.2f * grain;
      } else {
        rgb[0] = 0.45f + 0.25f * tint + 0.2f * grain;
        rgb[1] = 0.18f + 0.12f * tint + 0.15f * grain;
        rgb[2] = 0.12f + 0.08f * tint + 0.1f * grain;
      }
      for (int c = 0; c < 3; ++c) image.pixels[(size_t(y) * width + x) * 3 + c] = std::fmin(1.0f, rgb[c]);
    }
  return image;
}

}  // namespace texsynth_test
