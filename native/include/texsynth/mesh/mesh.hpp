// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// A validated polygon mesh with compact adjacency, built once per synthesis call.
// Positions and polygon arrays are BORROWED from the PolyMeshInput (no copy): the caller keeps
// them alive while the Mesh is used. Derived data (one-rings, normals, components) is owned.
//
// Tolerated: boundaries, several components, non-manifold edges, loose vertices (no corners),
// duplicate vertices, repeated vertices inside a polygon, zero-area polygons (never NaN: such
// polygons and isolated vertices get a fallback normal).
#include <atomic>
#include <cstdint>
#include <vector>

#include "texsynth/common/uninitialized_vector.hpp"
#include "texsynth/mesh/poly_mesh.hpp"

namespace texsynth {

struct Mesh {
  int32_t num_vertices = 0;
  int32_t num_corners = 0;
  int32_t num_polys = 0;
  const float* positions = nullptr;     // borrowed, num_vertices*3
  const int32_t* corner_verts = nullptr;  // borrowed
  const int32_t* poly_starts = nullptr;   // borrowed
  const int32_t* poly_sizes = nullptr;    // borrowed

  // One-rings in CSR form: distinct edge neighbours of v are
  // neighbours[neighbour_start[v] .. neighbour_start[v+1]), sorted ascending, never v itself.
  // Each undirected edge appears twice (once per endpoint), so num_edges = neighbours.size() / 2.
  UninitializedVector<int32_t> neighbour_start;  // num_vertices + 1
  UninitializedVector<int32_t> neighbours;

  // Corners of each vertex, ascending (= polygon order): the per-vertex gathers that replace
  // scatter loops, so vertex quantities are built in parallel with a fixed summation order.
  UninitializedVector<int32_t> vertex_corner_start;  // num_vertices + 1
  UninitializedVector<int32_t> vertex_corners;       // num_corners
  UninitializedVector<int32_t> corner_poly;          // num_corners: the polygon each corner belongs to

  UninitializedVector<float> normals;       // num_vertices*3, unit length
  UninitializedVector<int32_t> component;   // per vertex: connected component id, -1 for loose vertices
  int32_t num_components = 0;       // components with at least one corner

  int64_t num_edges() const { return static_cast<int64_t>(neighbours.size()) / 2; }
  int32_t degree(int32_t v) const { return neighbour_start[v + 1] - neighbour_start[v]; }
  bool all_triangles() const;
  int32_t max_poly_size() const;
};

// Validates `in` and builds the adjacency. `normals` (num_vertices*3) is optional: when null,
// area-weighted vertex normals are computed; when given, each must be finite and is normalised
// (zero vectors get the computed normal). Throws std::invalid_argument naming the first problem,
// texsynth::Cancelled when *cancel is raised.
Mesh build_mesh(const PolyMeshInput& in, const float* normals = nullptr, const std::atomic<bool>* cancel = nullptr);

}  // namespace texsynth
