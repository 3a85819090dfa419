// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The particle benches' mesh: a 101,760-face UV sphere of radius 1 with small radial bumps (±3 %),
// all triangles (irregular, skinny ones at the poles).
#include <cmath>

#include "../neighbourhood_fixtures.hpp"

namespace bench_fixtures {

inline ring_fixtures::TriMesh bumpy_sphere() {
  const fixtures::TestMesh uv = fixtures::uv_sphere(160, 320, 1.0, 1e-5);  // noise > 0: all triangles
  ring_fixtures::TriMesh m;
  m.positions = uv.positions;
  m.triangles = uv.corner_verts;
  for (int32_t v = 0; v < m.num_vertices(); ++v) {
    float* p = &m.positions[3 * size_t(v)];
    const double bump = 1 + 0.03 * std::sin(5 * p[0]) * std::sin(4 * p[1] + 1) * std::sin(3 * p[2] + 2);
    for (int k = 0; k < 3; ++k) p[k] = float(p[k] * bump);
  }
  return m;
}

}  // namespace bench_fixtures
