// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Fuzzed Blender-layout meshes shared by the mesh-consuming fuzz targets: arbitrary topology with
// hostile indices and coordinates, or a small jittered grid (so that code past validation runs).
#include <algorithm>
#include <initializer_list>
#include <vector>

#include "fuzz_common.hpp"
#include "texsynth/mesh/poly_mesh.hpp"

namespace fuzz {

struct FuzzMesh {
  std::vector<float> positions;
  std::vector<int32_t> corners, starts, sizes;
  int32_t num_vertices = 0;
  texsynth::PolyMeshInput input() const {
    return {positions.data(), num_vertices, corners.data(),        int32_t(corners.size()),
            starts.data(),    sizes.data(), int32_t(starts.size())};
  }
};

// Out-of-range indices, odd polygon sizes, inconsistent offsets, hostile coordinates.
inline FuzzMesh random_mesh(FuzzedDataProvider& in, int32_t max_vertices, int32_t max_polys) {
  FuzzMesh m;
  m.num_vertices = in.ConsumeIntegralInRange<int32_t>(0, max_vertices);
  m.positions.resize(size_t(m.num_vertices) * 3);
  for (auto& x : m.positions) x = hostile_float(in, -4, 4);
  const int32_t np = in.ConsumeIntegralInRange<int32_t>(0, max_polys);
  const bool consistent_starts = in.ConsumeIntegralInRange<int>(0, 7) != 0;
  for (int32_t f = 0; f < np; ++f) {
    const int32_t size = in.ConsumeIntegralInRange<int32_t>(0, 7) ? in.ConsumeIntegralInRange<int32_t>(3, 5)
                                                                   : in.ConsumeIntegralInRange<int32_t>(-3, 24);
    m.sizes.push_back(size);
    m.starts.push_back(consistent_starts ? int32_t(m.corners.size()) : in.ConsumeIntegralInRange<int32_t>(-3, 200));
    for (int32_t c = 0; c < std::max(size, 0); ++c)
      m.corners.push_back(in.ConsumeIntegralInRange<int32_t>(-1, m.num_vertices));
  }
  return m;
}

// A (w x h)-quad grid, optionally split into triangles, jittered, with a few hostile coordinates.
inline FuzzMesh grid_mesh(FuzzedDataProvider& in) {
  FuzzMesh m;
  const int w = in.ConsumeIntegralInRange<int>(1, 7), h = in.ConsumeIntegralInRange<int>(1, 7);
  const bool triangles = in.ConsumeBool();
  const float spacing = hostile_float(in, 0.01f, 3.f);
  m.num_vertices = (w + 1) * (h + 1);
  for (int y = 0; y <= h; ++y)
    for (int x = 0; x <= w; ++x) {
      const bool hostile = in.ConsumeIntegralInRange<int>(0, 15) == 0;
      m.positions.push_back(hostile ? hostile_float(in, -4, 4) : x * spacing);
      m.positions.push_back(y * spacing);
      m.positions.push_back(in.ConsumeFloatingPointInRange<float>(-0.2f, 0.2f) * spacing);
    }
  auto face = [&](std::initializer_list<int32_t> vs) {
    m.starts.push_back(int32_t(m.corners.size()));
    m.sizes.push_back(int32_t(vs.size()));
    m.corners.insert(m.corners.end(), vs);
  };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int32_t a = y * (w + 1) + x, b = a + 1, c = a + w + 2, d = a + w + 1;
      if (triangles)
        face({a, b, c}), face({a, c, d});
      else
        face({a, b, c, d});
    }
  return m;
}

inline FuzzMesh any_mesh(FuzzedDataProvider& in) { return in.ConsumeBool() ? grid_mesh(in) : random_mesh(in, 40, 32); }

}  // namespace fuzz
