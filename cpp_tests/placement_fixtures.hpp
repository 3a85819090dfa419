// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Particle-placement fixtures shared by the tests and the benchmark: samples drawn from labels whose
// arrangement is known, their analysis, a torus and its ring field.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "neighbourhood_fixtures.hpp"
#include "texsynth/common/rng.hpp"
#include "texsynth/particles/analysis.hpp"

namespace placement_fixtures {

constexpr double kPi = 3.14159265358979323846;

// A sample given by its labels (class per pixel, 0 = background); colours follow the class.
struct LabelSample {
  int W = 0, H = 0;
  std::vector<int32_t> labels;
  void fill(int x0, int y0, int w, int h, int32_t cls) {
    for (int y = std::max(0, y0); y < std::min(H, y0 + h); ++y)
      for (int x = std::max(0, x0); x < std::min(W, x0 + w); ++x) labels[size_t(y) * W + x] = cls;
  }
  void disc(double cx, double cy, double r, int32_t cls) {
    for (int y = std::max(0, int(cy - r) - 1); y < std::min(H, int(cy + r) + 2); ++y)
      for (int x = std::max(0, int(cx - r) - 1); x < std::min(W, int(cx + r) + 2); ++x)
        if (std::hypot(x + 0.5 - cx, y + 0.5 - cy) <= r) labels[size_t(y) * W + x] = cls;
  }
};

inline LabelSample blank(int W, int H) { return {W, H, std::vector<int32_t>(size_t(W) * H, 0)}; }

inline texsynth::ParticleAnalysis analyse(const LabelSample& s) {
  std::vector<float> px(s.labels.size() * 3);
  for (size_t i = 0; i < s.labels.size(); ++i)
    for (int c = 0; c < 3; ++c) px[3 * i + c] = 0.1f + 0.2f * float(s.labels[i]) + 0.05f * float(c);
  texsynth::ParticleAnalysisParams p;
  p.labels = s.labels;
  p.background = 0;
  return texsynth::analyse_particles({px.data(), s.W, s.H, 3}, p);
}

// Discs of radius 7..10 px on a 32 px lattice, each moved by up to ±5 px: an irregular arrangement of
// known mean spacing (32 px).
constexpr double kDiscSpacing = 32;
inline LabelSample jittered_discs(int W = 256, uint64_t seed = 9, int32_t cls = 1) {
  LabelSample s = blank(W, W);
  texsynth::Rng rng(seed);
  for (double y = 20; y + 12 < W; y += kDiscSpacing)
    for (double x = 20; x + 12 < W; x += kDiscSpacing) {
      // Drawn one by one: function arguments are evaluated in an unspecified order (gcc: last first,
      // clang: first first), so three draws in one call gave each compiler another sample.
      const double r = 7 + 3 * rng.uniform();
      const double dy = 10 * (rng.uniform() - 0.5);
      const double dx = 10 * (rng.uniform() - 0.5);
      s.disc(x + dx, y + dy, r, cls);
    }
  return s;
}

// Torus around z: R the ring radius, r the tube's; `ring` x `tube` quads split in two.
inline ring_fixtures::TriMesh torus(int ring, int tube, double R, double r) {
  ring_fixtures::TriMesh m;
  for (int i = 0; i < ring; ++i)
    for (int j = 0; j < tube; ++j) {
      const double u = 2 * kPi * i / ring, v = 2 * kPi * j / tube;
      m.add_vertex((R + r * std::cos(v)) * std::cos(u), (R + r * std::cos(v)) * std::sin(u), r * std::sin(v));
    }
  auto id = [&](int i, int j) { return int32_t((i % ring) * tube + (j % tube)); };
  for (int i = 0; i < ring; ++i)
    for (int j = 0; j < tube; ++j) {
      m.add_triangle(id(i, j), id(i + 1, j), id(i + 1, j + 1));
      m.add_triangle(id(i, j), id(i + 1, j + 1), id(i, j + 1));
    }
  return m;
}

// "up" along the ring (around z) at every vertex: no zeros on a torus.
inline std::vector<float> ring_field(const ring_fixtures::TriMesh& m) {
  std::vector<float> d;
  for (int32_t v = 0; v < m.num_vertices(); ++v) {
    const double x = m.positions[3 * size_t(v)], y = m.positions[3 * size_t(v) + 1], l = std::hypot(x, y);
    d.insert(d.end(), {float(-y / l), float(x / l), 0.f});
  }
  return d;
}

}  // namespace placement_fixtures
