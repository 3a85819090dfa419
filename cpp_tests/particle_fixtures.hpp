// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Samples drawn pixel by pixel for the particle-analysis tests: a flat ground, shapes painted on it, noise.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "texsynth/common/rng.hpp"
#include "texsynth/particles/analysis.hpp"

namespace particle_fixtures {

struct Colour {
  float r, g, b;
};

// A warm grey of brightness v: one number per shade when only the contrast matters.
constexpr Colour tone(float v) { return {v, 0.9f * v, 0.8f * v}; }

struct Scene {
  int W = 0, H = 0;
  std::vector<float> px;  // W x H x 3, row 0 at the bottom
  texsynth::ParticleSample view() const { return {px.data(), W, H, 3}; }
  void set(int x, int y, Colour c) {
    float* p = &px[(size_t(y) * W + x) * 3];
    p[0] = c.r, p[1] = c.g, p[2] = c.b;
  }
  void set(int x, int y, float v) { set(x, y, tone(v)); }
};

inline Scene flat(int W, int H, Colour c) {
  Scene s{W, H, std::vector<float>(size_t(W) * H * 3)};
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) s.set(x, y, c);
  return s;
}
inline Scene flat(int W, int H, float v) { return flat(W, H, tone(v)); }

// Uniform noise in [-amplitude, amplitude] on every channel, seeded.
inline void add_noise(Scene& s, float amplitude, uint64_t seed) {
  texsynth::Rng rng(seed);
  for (float& v : s.px) v += float(amplitude * (2 * rng.uniform() - 1));
}

}  // namespace particle_fixtures
