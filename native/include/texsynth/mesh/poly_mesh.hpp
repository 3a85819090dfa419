// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// A polygon mesh exactly as Blender stores it, so the add-on passes its arrays without conversion.
#include <array>
#include <cstdint>
#include <vector>

namespace texsynth {

using Vec3f = std::array<float, 3>;

struct PolyMeshInput {
  const float* positions = nullptr;        // num_vertices*3
  int32_t num_vertices = 0;
  const int32_t* corner_verts = nullptr;   // num_corners (Blender "loops": corner -> vertex)
  int32_t num_corners = 0;
  const int32_t* poly_starts = nullptr;    // num_polys (first corner of each polygon)
  const int32_t* poly_sizes = nullptr;     // num_polys
  int32_t num_polys = 0;
};

}  // namespace texsynth
