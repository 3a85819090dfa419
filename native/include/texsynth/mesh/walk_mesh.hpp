// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// A triangle mesh prepared for walks across its faces: straight lines unfolded over edges (round
// neighbourhoods) and integral curves of a direction field (vector-field patches) share it.
//
// The mesh is welded by exactly equal positions (UV-seam splits and split-vertex imports connect).
// Walks cross only edges shared by exactly two non-degenerate, consistently oriented triangles; every
// other edge (boundary, non-manifold, flipped neighbour, zero-area face) is a wall.
#include <array>
#include <atomic>
#include <cstdint>
#include <vector>

#include "texsynth/mesh/vec_math.hpp"

namespace texsynth {

// A triangle mesh as Blender's loop triangles give it (triangle corners -> vertices).
struct TriangleMeshInput {
  const float* positions = nullptr;    // num_vertices*3, finite
  int32_t num_vertices = 0;
  const int32_t* triangles = nullptr;  // num_triangles*3, each in [0, num_vertices)
  int32_t num_triangles = 0;
};

// |e1 × e2| below this × (longest edge)² is a zero-area triangle: its barycentric gradients would be
// noise at float precision, so it is a wall, never entered (and never NaN).
constexpr double kDegenerateRelativeArea = 1e-7;

// Per triangle of the welded walk mesh.
struct WalkTriangle {
  V3 grad1, grad2;  // ∇β1, ∇β2 in the triangle's plane (β0 = 1 - β1 - β2): rates of a unit 3D direction
  V3 normal;        // unit geometric normal, for the facing test and the unfolding
  std::array<double, 3> inv_edge{};  // 1 / |edge k|: unit edge vectors without a square root per crossing
  // Across edge k (corner k -> k+1): (neighbour << 2) | neighbour's edge, or -1 where a walk stops
  // (boundary, non-manifold, inconsistent orientation, degenerate on either side).
  std::array<int32_t, 3> across{-1, -1, -1};
  bool degenerate = true;
};

struct WalkMesh {
  std::vector<int32_t> weld;    // vertex -> smallest-index vertex at exactly the same position
  std::vector<V3> vertex_normal;  // area-weighted, per weld representative (unit or zero)
  std::vector<WalkTriangle> tris;
};

inline V3 mesh_position(const TriangleMeshInput& m, int32_t v) { return v3(m.positions + 3 * size_t(v)); }

// Builds weld, triangle geometry, welded vertex normals and edge links. Same result for any thread
// count. Inputs are not validated here (callers check indices and finiteness first); throws
// texsynth::Cancelled when *cancel is raised.
WalkMesh build_walk_mesh(const TriangleMeshInput& mesh, const std::atomic<bool>* cancel = nullptr);

// Bytes a WalkMesh and its construction need at the peak, for callers' memory estimates.
int64_t walk_mesh_peak_bytes(int64_t num_triangles, int64_t num_vertices);

// Rotates v about n × nt by the angle from n to nt (c = n·nt > -1), the minimal rotation taking n to
// nt: maps one tangent plane onto the other keeping angles (a projection would squeeze them where
// the smooth normal differs from the face normal).
inline V3 rotate_between(V3 v, V3 n, V3 nt, double c) {
  const V3 a = cross(n, nt);
  return v * c + cross(a, v) + a * (dot(a, v) / (1 + c));
}

}  // namespace texsynth
