// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Texture particles, Blender output (docs/algorithms/texture_particles.md, "Decals and the analysis cache"
// and "In Blender"):
// per placed particle, the target faces under its sprite rectangle, clipped to it, as decal polygons.
//
// Per particle: the anchor point x0 (smooth normal n0), the tangent frame u = the axis projected into
// the tangent plane, v = n0 × u, and a rectangle [u0, u1] × [v0, v1] (world units, relative to x0,
// containing x0). The patch is a flood fill from the anchor's triangle across walk-mesh edges (walls
// stop it) through faces whose normal lies within max_normal_angle of n0 and whose projection onto
// the (u, v) plane overlaps the rectangle. Each face is clipped to the rectangle in that plane; clip
// points are placed by barycentrics on the original face (exactly on the surface), then moved by
// `offset` along the smooth normal. Faces beyond the angle (the far side of a fold, a thin part's
// back) are left out, so no surface point is mapped twice through a fold. A surface that winds over
// itself with every normal within the angle (a spiral ramp) can still be mapped twice: counted, not cut.
//
// Vertices are shared within one particle's decal (smooth shading, continuous UVs): a mesh vertex by
// its weld representative, a mesh edge × rectangle side by (edge, side), a rectangle corner by its
// number. Corner UVs map the rectangle onto the atlas cell: (u0, v0) -> (s0, t0), (u1, v1) -> (s1, t1)
// exactly. Polygons keep the target's winding. Results are concatenated in particle order: the same
// bytes at any thread count.
//
// Curved: footprint radius R (farthest rectangle corner from x0) × curvature κ > 0.5 (the projection
// squashes the sprite by more than ~4 % there). κ = the largest angle between a decal vertex's smooth
// normal and n0 per unit distance from x0, over vertices at least R / 4 away.
#include <array>
#include <atomic>
#include <cstdint>
#include <vector>

#include "texsynth/mesh/vec_math.hpp"
#include "texsynth/particles/surface_walk.hpp"

namespace texsynth {

struct DecalParticle {
  SurfacePoint anchor;
  V3 axis;                           // world direction of the rectangle's u axis (projected into the tangent plane)
  std::array<double, 4> rect{};      // u0, v0, u1, v1: u0 <= 0 <= u1, v0 <= 0 <= v1, u0 < u1, v0 < v1
  std::array<double, 4> uv_rect{};   // s0, t0, s1, t1: atlas cell
};

constexpr int32_t kMaxDecalStackLevel = 255;

struct DecalOptions {
  double offset = 0;                 // along the smooth normal, world units, finite
  // Overlapping decals of one call would lie at one height and z-fight. With stack_step > 0, decals whose
  // rectangles overlap get different levels (DecalMesh::level, a greedy colouring in particle order) and lie
  // stack_step higher per level; a bake composites the higher level on top, as a render shows it. Levels are
  // capped at max_level (0..kMaxDecalStackLevel), so a caller can keep each call's decals in a band of known
  // height. stack_step 0 = every decal at `offset`, level 0. World units, finite, >= 0.
  double stack_step = 0;
  int32_t max_level = kMaxDecalStackLevel;
  double max_normal_angle = 75;      // degrees, in (0, 90)
  int32_t max_faces_per_particle = 100000;  // patch faces per particle (stats.capped beyond it)
  const std::atomic<bool>* cancel = nullptr;
};

struct DecalStats {
  int64_t particles = 0;
  int64_t empty = 0;           // particles with no polygon (degenerate anchor face)
  int64_t capped = 0;          // particles whose patch hit max_faces_per_particle
  int64_t curved = 0;
  int64_t faces_visited = 0;   // faces tested by the flood fills
  int64_t faces_folded = 0;    // faces left out for their normal
  int64_t overlapping = 0;     // particles whose decal covers part of its rectangle twice (coverage > 1):
                               // a surface winding over itself within the normal angle (a spiral ramp)
  int64_t stacked = 0;         // particles lifted (level > 0)
  int64_t unstacked = 0;       // particles left at level 0 untested (the stacking's work bound; see decals.cpp)
  int32_t max_level = 0;       // highest stacking level (the call's decals span offset .. offset + max_level × step)
  double min_coverage = 0;     // smallest (decal area in the (u, v) plane / rectangle area); < 1 at walls
  double mean_coverage = 0;
  double seconds = 0;
};

// Blender's polygon layout: polygon f has loop_totals[f] corners from loop_starts[f] in corner_verts.
struct DecalMesh {
  std::vector<float> positions;       // P × 3
  std::vector<int32_t> loop_starts, loop_totals;
  std::vector<int32_t> corner_verts;  // C
  std::vector<float> corner_uvs;      // C × 2
  std::vector<int32_t> face_particle; // F: particle index
  // Where each polygon lies on the target (for compositing the decals into a bake image in texture space):
  // the triangle, and per corner its barycentrics (b1, b2) there (b0 = 1 - b1 - b2), before the offset.
  std::vector<int32_t> face_triangle;       // F
  std::vector<float> corner_barycentric;    // C × 2
  std::vector<uint8_t> curved;        // per particle, 0 / 1
  std::vector<int32_t> level;         // per particle, its stacking level (DecalOptions::stack_step)
  DecalStats stats;
};

// std::invalid_argument naming the first bad particle: anchor triangle out of range or barycentrics
// NaN/outside, axis NaN/zero/along the normal, rectangle NaN/empty/not containing the anchor, atlas
// cell NaN/infinite; or a bad option (offset not finite, stack_step negative or not finite, max_level outside 0..255, angle outside (0, 90), face cap < 1), or a
// result beyond 2^31 - 1 corners. texsynth::Cancelled when *cancel is raised.
DecalMesh build_decal_mesh(const SurfaceWalkMesh& mesh, const DecalParticle* particles, int64_t count,
                           const DecalOptions& options);

}  // namespace texsynth
