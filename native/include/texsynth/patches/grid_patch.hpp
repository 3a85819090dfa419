// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Local resampling in a direction field (Chen, Liu & Dong, §3; docs/algorithms/vector_field_patches.md,
// "Tracing"): a regular grid patch around a surface point, built by tracing integral curves of the
// texture's direction field ("up", sample +y) and of its orthogonal field (sample +x = up × normal, so the
// texture is not mirrored seen from outside), one grid step at a time.
//
// Decisions where the paper is silent ("Tracing" and "Thin parts" there; tests in
// cpp_tests/test_patches_grid.cpp):
//  - Field inside a face: the three vertex vectors (unit length) projected into the face plane and
//    interpolated linearly in barycentrics, then normalised. Where the interpolated vector is
//    shorter than singular_threshold the field has a singularity (source, sink, umbilic) and the trace
//    stops.
//  - Integrator: midpoint RK2, sub-steps of at most half a grid step (PatchFieldParams::substep), clipped at edges. After an
//    edge the direction is re-read from the new face's field; if that points straight back across the
//    edge just crossed (a field tangent to the edge, or a fold), the step slides along the edge.
//  - Step length: one grid step has ∫ ds / h(x) = 1 with h(x) = spacing · g(x), g = 1 / density (or
//    |v| / median |v| with magnitude_scale), clamped to [1/4, 4]: the local feature size is
//    proportional to g, i.e. features twice as dense where TexSynth's scale field is 2.
//  - Grid order: the centre row and column first, then each other point from its two neighbours
//    nearer the centre (one step along x from one, along y from the other). Both reached: the 3D
//    midpoint snapped to the nearer of the two faces; more than half a step apart: invalid.
//  - A trace stops (its point and every point traced from it invalid) at boundary, non-manifold or
//    degenerate edges, at singularities, and after max_crossings edge crossings within one step.
//  - Cells: valid when their four corners are, their area is within [0.1, 4] local h², and they are
//    not flipped against the surface normal.
#include <atomic>
#include <cstdint>
#include <vector>

#include "texsynth/mesh/walk_mesh.hpp"

namespace texsynth {

constexpr int32_t kMaxGridPatchSize = 256;
constexpr double kMinGridScale = 0.25, kMaxGridScale = 4.0;

// A point on the mesh: triangle and barycentrics (b1, b2) of its corners 1 and 2 (b0 = 1 - b1 - b2).
struct FacePoint {
  int32_t triangle = -1;  // -1: none (an invalid grid point)
  float b1 = 0, b2 = 0;
};

struct PatchFieldInput {
  TriangleMeshInput mesh;               // borrowed for the duration of build_patch_field only
  const float* directions = nullptr;    // num_vertices*3: the texture's up. Zero or non-finite = unset
  const float* density = nullptr;       // optional num_vertices: scale field (2 = features half as large)
  bool magnitude_scale = false;         // the directions' lengths set g instead (g = |v| / median |v|)
};

struct PatchFieldParams {
  double spacing = 0;                 // world distance of one grid step where g = 1 (> 0, finite)
  int32_t max_crossings = 64;         // edge crossings within one grid step before the trace gives up
  double singular_threshold = 1e-3;   // |interpolated unit field| below this: singular, the trace stops
  // RK2 sub-step in grid steps, [0.05, 1]. Half a step traces the test surfaces (cylinder, sphere) as
  // exactly as a quarter (centre row and column within 0.005 steps of the exact curves) in half the time
  // (bench_patches_grid).
  double substep = 0.5;
  // A field built before on the same mesh (positions and triangles compared exactly): its walk mesh is
  // copied instead of rebuilt, which was half of a live preview after a comb stroke. Ignored otherwise.
  const struct PatchField* reuse_mesh = nullptr;
  const std::atomic<bool>* cancel = nullptr;
};

// The mesh and field prepared for tracing; immutable, shared by any number of traces and threads.
struct PatchField {
  std::vector<float> positions;          // copy, num_vertices*3
  std::vector<int32_t> triangles;        // copy, num_triangles*3
  TriangleMeshInput mesh() const {
    return {positions.data(), int32_t(positions.size() / 3), triangles.data(), int32_t(triangles.size() / 3)};
  }
  WalkMesh walk;
  std::vector<V3> corner_field;          // 3 per triangle: unit vertex up projected into the face plane
  std::vector<float> scale;              // per vertex: g in [kMinGridScale, kMaxGridScale]
  double spacing = 0;
  int32_t max_crossings = 64;
  double singular_threshold = 1e-3;
  double substep = 0.5;
  int64_t unset_vertices = 0;            // vertices whose direction was filled from a neighbour
  bool reused_mesh = false;              // the walk mesh was copied from PatchFieldParams::reuse_mesh
};

// Throws std::invalid_argument for: counts or indices out of range, NaN/inf positions, a density that
// is not finite and > 0, spacing not finite and > 0, max_crossings < 1, no vertex with a set direction;
// texsynth::Cancelled when *cancel is raised. Unset directions take the nearest set vertex's (breadth
// first along mesh edges, deterministic).
PatchField build_patch_field(const PatchFieldInput& in, const PatchFieldParams& params);

// Grid points (i, j), i along sample +x and j along +y, at index j·size + i; the centre is (size/2, size/2).
struct GridPatches {
  int32_t size = 0;
  int32_t count = 0;
  std::vector<FacePoint> points;    // count·size²
  std::vector<float> positions;     // count·size²·3 (0 where invalid: never NaN)
  std::vector<uint8_t> cell_valid;  // count·(size-1)²: cell (i, j) at index j·(size-1) + i
  int64_t invalid_points = 0;
  int64_t invalid_cells = 0;
};

// Traces one patch per centre, in parallel; identical results for any thread count. Throws
// std::invalid_argument for a size outside [2, kMaxGridPatchSize], centres outside the mesh or with
// barycentrics outside their triangle; texsynth::Cancelled when *cancel is raised.
GridPatches trace_grid_patches(const PatchField& field, const FacePoint* centres, int32_t count, int32_t size,
                               const std::atomic<bool>* cancel = nullptr);

// Appends `more` (same size) after the patches of `into`: each patch is traced on its own, so the
// result equals tracing all centres at once. Throws std::invalid_argument for another size.
void append_grid_patches(GridPatches& into, const GridPatches& more);

// Where a point lies within a grid cell (corners p00, p10, p11, p01 counter-clockwise in the grid), by
// inverse bilinear interpolation in the cell's mean plane. The paper's paste formula (§3.2) neither sums to
// one nor reproduces corner values (vector_field_patches.md, "Paste"); bilinear weights (1-s)(1-t), s(1-t),
// st, (1-s)t do both. `distance` is the point's distance from the cell's mean plane.
struct CellCoordinates {
  double s = 0, t = 0;
  double distance = 0;
  bool ok = false;  // false for a degenerate cell
};
CellCoordinates cell_coordinates(V3 p00, V3 p10, V3 p11, V3 p01, V3 point);

}  // namespace texsynth
