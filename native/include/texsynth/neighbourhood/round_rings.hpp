// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Direction-invariant round neighbourhoods (Chen & Dong 2008, §4.3;
// docs/algorithms/round_neighbourhoods.md, "Rings"), precomputed once per mesh, point set, radii and K.
//
// Each surface sample point P (a texel centre through the UV map, or a vertex) gets rings of radius
// m·r (m = 1..K). Ring m holds A_m = 8m bins; bin a is where a straightest-geodesic walk from P,
// leaving at angle theta = 2π·a/A_m counter-clockwise (about the outward normal n) from a
// geometry-only reference tangent t0, has travelled arc length m·r. The texture direction field is
// NOT an input: at synthesis time direction_angle() gives the field's angle from t0 and ring_sample()
// interpolates between the two bins around each template angle, so re-orienting the field never
// recomputes this.
//
// Why a radial walk rather than the paper's cylinder cuts: on a plane both give the same points; on
// open or broken rings (boundaries, holes, thin parts) each point still has a defined angle, and a
// point past a boundary is simply invalid (round_neighbourhoods.md, "Rings").
//
// Walks run on a copy of the mesh welded by exactly equal positions (UV-seam splits and split-vertex
// imports connect). A walk is a straight line inside each face, unfolded across each edge (rotated
// about it, keeping its angle to the edge). It stops, leaving its remaining ring points invalid, at a
// boundary edge, a non-manifold edge (3+ faces), an edge whose two faces disagree in orientation, a
// zero-area face, a face turned more than the facing limit from the centre's normal (the back of a
// thin sheet, the far side of a small sphere), or after max_steps edge crossings.
#include <atomic>
#include <cstdint>
#include <vector>

#include "texsynth/common/uninitialized_vector.hpp"
#include "texsynth/mesh/walk_mesh.hpp"

namespace texsynth {

// The sample points: P = (1 - b1 - b2)·p0 + b1·p1 + b2·p2 of triangle[i]'s corners.
struct SurfacePoints {
  const int32_t* triangle = nullptr;     // num_points, in [0, num_triangles)
  const float* barycentric = nullptr;    // num_points*2: (b1, b2), >= 0 and b1 + b2 <= 1 (±1e-4, then clamped)
  const float* radius = nullptr;         // num_points: r_i = global scale × scale field, finite and > 0
  int32_t num_points = 0;
};

constexpr int kMaxRings = 6;
// Peak-memory refusal threshold: K = 4 at ~700k points (~470 MB) fits with room for the rest of a
// 1.5 GB synthesis; K = 6 at the same count (~960 MB) does not.
constexpr double kDefaultRoundRingsMaxMegabytes = 768.0;

struct RoundRingsParams {
  int rings = 4;                       // K, 1..kMaxRings
  double facing_limit_degrees = 75.0;  // a walk stops entering a triangle whose normal is further from n; (0, 180]
  int32_t max_steps = 4096;            // edge crossings per walk before it is abandoned (invalid); >= 1
  double max_megabytes = kDefaultRoundRingsMaxMegabytes;  // refuse when the estimated peak is above (MB = 1e6 B)
  const std::atomic<bool>* cancel = nullptr;
};

// One (point, ring, bin) entry: 8 bytes. triangle = -1: the walk never got there (boundary,
// non-manifold or degenerate edge, facing limit, step cap). Barycentrics of the triangle's corners
// 1 and 2 as value/65535 (corner 0 gets the rest); b1 + b2 <= 65535.
struct RingPoint {
  int32_t triangle;
  uint16_t b1, b2;
};
static_assert(sizeof(RingPoint) == 8, "RingPoint must stay 8 bytes");

// Ring m (1-based) starts at entry 8·(1 + ... + (m-1)) = 4m(m-1) of a point's block and has 8m bins.
constexpr int ring_bins(int m) { return 8 * m; }
constexpr int ring_offset(int m) { return 4 * m * (m - 1); }
constexpr int ring_entries(int rings) { return 4 * rings * (rings + 1); }  // = ring_offset(K + 1)

struct RoundRings {
  int32_t num_points = 0;
  int rings = 0;                  // K
  int entries_per_point = 0;      // ring_entries(K)
  // Point-major: point i's block is points[i*entries_per_point ..), rings in order, bins in order.
  // Not zero-filled on resize: the parallel pass writes every entry (and first touches the pages).
  UninitializedVector<RingPoint> points;
  // Per point: unit outward normal n (smooth, welded-mesh vertex normals interpolated) and unit
  // reference tangent t0 ⟂ n (the containing triangle's first edge rotated from the face plane into
  // the tangent plane, so on the face bin 0 leaves exactly along that edge); num_points*3 each.
  std::vector<float> normal, tangent;
  // Invalid entries in total and per ring (index m-1), for the caller's log.
  int64_t invalid_count = 0;
  std::vector<int64_t> invalid_per_ring;

  const RingPoint* point_block(int32_t i) const { return points.data() + size_t(i) * size_t(entries_per_point); }
  double invalid_fraction() const {
    return points.empty() ? 0.0 : double(invalid_count) / double(points.size());
  }
};

struct RoundRingsMemory {
  int64_t result_bytes = 0;  // what the returned RoundRings keeps: 8 B per entry + 24 B frame per point
  int64_t peak_bytes = 0;    // result plus the welded walk mesh alive while building
};
RoundRingsMemory estimate_round_rings_memory(int64_t num_points, int64_t num_triangles, int64_t num_vertices,
                                             int rings);

// Validates everything (std::invalid_argument naming the first problem: NaN/inf positions,
// out-of-range indices, barycentrics outside the triangle, radius not finite or <= 0 -- the caller
// clamps its scale field, we do not guess a radius -- K outside 1..6, memory above the limit with
// the MB figures), then builds the rings in parallel over points; the bytes are identical whatever
// the thread count. Throws texsynth::Cancelled when *params.cancel is raised.
RoundRings build_round_rings(const TriangleMeshInput& mesh, const SurfacePoints& points,
                             const RoundRingsParams& params = {});

// Angle of dir projected onto point i's tangent plane, counter-clockwise about n from t0, in
// [0, 2π). When the projection has (near) zero length or dir is not finite: 0, *defined = false.
float direction_angle(const RoundRings& rings, int32_t point, const float dir[3], bool* defined = nullptr);

// Continuous angle phi (radians from t0, any value; NaN/inf treated as 0) on ring m (1-based):
// value ≈ (1 - weight)·bin[bin0] + weight·bin[bin1], bins of that ring (0..8m-1), bin1 = bin0 + 1 mod 8m.
struct RingSample {
  int bin0 = 0, bin1 = 0;
  float weight = 0.f;  // of bin1, in [0, 1)
};
RingSample ring_sample(int ring, float phi);

}  // namespace texsynth
