// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Per-vertex principal curvature directions, for the "from curvature" field preset.
//
// Shape operator per vertex: normal curvatures toward every vertex sharing a polygon with it
// (edges and diagonals), k_ij = 2 n_i·(p_i − p_j) / |p_j − p_i|² (positive on convex surfaces with
// outward normals), fitted by least squares to a symmetric 2×2 form in the tangent plane
// (Taubin-style estimate; a tiny ridge term keeps degenerate rings defined), then averaged over one-rings
// `smoothing_rings` times (as 3×3 tensors, re-projected) to tame triangulation noise.
//
// The returned direction is the principal direction of SMALLER |curvature| (the "flattest" way:
// along a cylinder's axis whether convex or concave). Principal directions are lines, not vectors,
// so signs are made consistent by a breadth-first walk. Where the surface is nearly flat or
// umbilic (|k1| − |k2| < anisotropy_threshold × max(|k1|, |k2|), or both ≈ 0) the direction is
// undefined and returned as the zero vector, for the orientation field to fill in.
#include <vector>

#include "texsynth/mesh/mesh.hpp"

namespace texsynth {

struct CurvatureParams {
  int smoothing_rings = 2;
  double anisotropy_threshold = 0.2;
};

struct CurvatureResult {
  std::vector<float> min_direction;  // num_vertices*3, unit tangent vectors or zero (undefined)
  std::vector<float> curvatures;     // num_vertices*2: (k_flat, k_steep), |k_flat| <= |k_steep|
};

// Throws std::invalid_argument for parameters out of range.
CurvatureResult principal_curvature_directions(const Mesh& mesh, const CurvatureParams& params = {});

}  // namespace texsynth
