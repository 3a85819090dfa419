// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Undirected edges of a mesh and the corners that use them (texton synthesis, its edge metric).
#include <cstdint>

#include "texsynth/common/uninitialized_vector.hpp"
#include "texsynth/mesh/mesh.hpp"

namespace texsynth {

struct MeshEdges {
  UninitializedVector<int32_t> vertices;      // num_edges*2, (a, b) with a < b, sorted
  UninitializedVector<int32_t> corner_edge;   // per corner: edge from this corner's vertex to the next corner's; -1 if equal
  UninitializedVector<int32_t> edge_corner_start;  // num_edges + 1 (CSR)
  UninitializedVector<int32_t> edge_corners;       // corners c with corner_edge[c] == e
  int32_t num_edges() const { return int32_t(vertices.size() / 2); }
};
MeshEdges build_mesh_edges(const Mesh& mesh);

}  // namespace texsynth
