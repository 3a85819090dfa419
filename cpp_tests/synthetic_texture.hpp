// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Texture-like synthetic samples for tests and benchmarks: jittered bricks with mortar, per-brick tint
// and value noise (sRGB-encoded RGB floats). Deterministic for a seed.
#include <tbb/parallel_for.h>

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

// An sRGB RGB image of the given size, pixels zero.
inline texsynth::Image blank_rgb(int width, int height) {
  texsynth::Image image;
  image.width = width;
  image.height = height;
  image.channels = 3;
  image.encoding = texsynth::ColorEncoding::kSrgb;
  image.pixels.resize(size_t(width) * height * 3);
  return image;
}

inline texsynth::Image brick_texture(int width, int height, uint64_t seed = 1) {
  texsynth::Image image = blank_rgb(width, height);
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

// Photo-like gravel (stand-in for a photographed sample, no outside data): jittered-grid pebbles
// with varying size, colour and a shaded bump, dark gaps, several octaves of noise and per-pixel
// sensor grain. `feature_px` is a pebble's typical diameter in pixels: scale it with the size to
// mimic an upscaled photo (same content, more pixels).
inline texsynth::Image gravel_texture(int width, int height, float feature_px = 18.0f, uint64_t seed = 5) {
  texsynth::Image image = blank_rgb(width, height);
  const float cell = feature_px;
  tbb::parallel_for(0, height, [&](int y) {
    for (int x = 0; x < width; ++x) {
      // Nearest and second-nearest jittered pebble centre (Worley noise).
      const int cx = int(std::floor(x / cell)), cy = int(std::floor(y / cell));
      float best = 1e9f, second = 1e9f;
      int bx = 0, by = 0;
      for (int j = -1; j <= 1; ++j)
        for (int i = -1; i <= 1; ++i) {
          const float px = (cx + i + 0.15f + 0.7f * lattice_noise(cx + i, cy + j, seed)) * cell;
          const float py = (cy + j + 0.15f + 0.7f * lattice_noise(cx + i, cy + j, seed + 1)) * cell;
          const float stretch = 0.7f + 0.6f * lattice_noise(cx + i, cy + j, seed + 2);
          const float d = std::hypot((x - px) * stretch, (y - py) / stretch) / cell;
          if (d < best) {
            second = best;
            best = d;
            bx = cx + i;
            by = cy + j;
          } else if (d < second) {
            second = d;
          }
        }
      const float edge = second - best;  // 0 on the border between two pebbles
      const float gap = std::fmin(1.0f, edge * 6.0f);
      const float bump = std::fmax(0.0f, 1.0f - best * 1.4f);
      const float tone = lattice_noise(bx, by, seed + 3), hue = lattice_noise(bx, by, seed + 4);
      const float grain = 0.5f * value_noise(float(x), float(y), cell * 0.12f + 1.0f, seed + 5) +
                          0.3f * value_noise(float(x), float(y), cell * 0.4f, seed + 6) +
                          0.2f * value_noise(float(x), float(y), cell * 3.0f, seed + 7);
      const float sensor = lattice_noise(x, y, seed + 8) - 0.5f;
      const float light = (0.35f + 0.45f * tone + 0.25f * bump) * (0.25f + 0.75f * gap) * (0.8f + 0.4f * grain);
      const float rgb[3] = {light * (0.95f + 0.15f * hue), light * (0.9f + 0.05f * hue), light * (0.8f - 0.1f * hue)};
      for (int c = 0; c < 3; ++c)
        image.pixels[(size_t(y) * width + x) * 3 + c] = std::fmin(1.0f, std::fmax(0.0f, rgb[c] + 0.03f * sensor));
    }
  });
  return image;
}

}  // namespace texsynth_test
