// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Texture particles, synthesis half (Dischler et al. 2002, §2.3; docs/algorithms/texture_particles.md,
// "Surface walks"): the pseudo-geodesic distance and its inverse.
//
// A normal section is the intersection of the surface with a plane through a point P that contains
// P's smooth normal (vertex normals interpolated by barycentrics). On the mesh it is a polyline,
// walked face to face by the signs of the corners' distances to the plane (topological: a walk never
// drifts off its plane, and a crossing found from one face is the crossing seen from the next).
// Lengths are the polyline's (sum of the segments within faces).
//  - Inverse of dist (walk_normal_section): from P, in a tangent direction projected into P's face,
//    walk `length` along the section of the plane spanned by that direction and P's smooth normal.
//  - dist (pseudo_geodesic_distance): the section of the plane spanned by P1P2 and N1 contains P2;
//    walk it from P1 towards P2 until P2's face is reached.
// A corner lying on the plane (within 1e-7 × the start face's longest edge) counts as lying on its
// positive side: the plane is nudged off the vertex, the same way from every face around it.
#include <atomic>
#include <cstdint>
#include <limits>
#include <vector>

#include "texsynth/mesh/vec_math.hpp"
#include "texsynth/mesh/walk_mesh.hpp"

namespace texsynth {

// A point on the mesh: triangle and barycentrics of its corners 1 and 2 (b0 = 1 - b1 - b2). Doubles,
// unlike FacePoint's floats: particles chain walks (parent -> child -> grandchild).
struct SurfacePoint {
  int32_t triangle = -1;
  double b1 = 0, b2 = 0;
};

enum class WalkStatus : uint8_t {
  reached = 0,     // walked the whole length (dist: reached P2)
  wall = 1,        // stopped at a boundary, non-manifold, flipped or degenerate neighbour's edge
  face_limit = 2,  // gave up after max_faces faces
  length_limit = 3,  // dist only: the section grew longer than max_length_factor × the chord
  no_plane = 4,    // no section: direction along the normal, zero direction or degenerate start face
};

struct SectionWalkOptions {
  int32_t max_faces = 10000;
  double max_length_factor = 3.0;  // dist: give up beyond this × |P1P2| (a section is never shorter)
};

struct SectionWalkResult {
  SurfacePoint end;        // where the walk stopped (on the wall's edge for `wall`)
  V3 position;             // of `end`
  V3 direction;            // unit direction of travel in the last face (0 when no_plane)
  double length = 0;       // arc length walked (polyline)
  int32_t faces = 0;       // faces entered, the start face included
  WalkStatus status = WalkStatus::no_plane;
};

// One walk. Inputs must be valid (see the batch version); throws nothing for valid inputs.
SectionWalkResult walk_normal_section(const WalkMesh& walk, const TriangleMeshInput& mesh, const SurfacePoint& start,
                                      V3 direction, double length, const SectionWalkOptions& options = {});

enum class DistanceKind : uint8_t {
  section = 0,           // the normal section of P1 (dist(P1, P2))
  reverse_section = 1,   // the normal section of P2 (dist(P2, P1)) was shorter or the only one
  chord = 2,             // neither section reached: |P1P2| as last resort
  opposite_normals = 3,  // N1·N2 < 0: the two sides of a thin part never conflict (distance = ∞)
};

struct PseudoGeodesic {
  double distance = std::numeric_limits<double>::infinity();
  DistanceKind kind = DistanceKind::chord;
};

// dist(P1, P2) of §2.3, one way: the section's arc length from P1 to P2, ∞ when P1P2 ∥ N1 (or P1 =
// P2 gives 0), when the walk meets a wall, or gives up (faces or length).
double pseudo_geodesic_distance_oneway(const WalkMesh& walk, const TriangleMeshInput& mesh, const SurfacePoint& p1,
                                       const SurfacePoint& p2, const SectionWalkOptions& options = {});

// The symmetric distance used for conflicts: ∞ (opposite_normals) when N1·N2 < 0, else
// min(dist(P1, P2), dist(P2, P1)), else the chord.
PseudoGeodesic pseudo_geodesic_distance(const WalkMesh& walk, const TriangleMeshInput& mesh, const SurfacePoint& p1,
                                        const SurfacePoint& p2, const SectionWalkOptions& options = {});

// The smooth normal at p: vertex normals interpolated, normalised; the face normal where they cancel.
V3 smooth_normal(const WalkMesh& walk, const TriangleMeshInput& mesh, const SurfacePoint& p);
V3 surface_position(const TriangleMeshInput& mesh, const SurfacePoint& p);

// Batches, parallel over walks (TBB), each result in its own slot: the same bytes at any thread count.
// std::invalid_argument naming the first bad item: triangle out of range, barycentrics NaN or outside
// the triangle (beyond 1e-4), direction NaN or zero, length NaN or <= 0, a bad option. Barycentrics
// within the tolerance are clamped into the triangle. texsynth::Cancelled when *cancel is raised.
// A point from the caller, checked as the batches check theirs (std::invalid_argument naming `who`,
// `what` and item i) and clamped into its triangle.
SurfacePoint checked_surface_point(const SurfacePoint& p, int32_t num_triangles, const char* who, const char* what,
                                   int64_t i);

struct SectionWalkRequest {
  SurfacePoint start;
  V3 direction;
  double length = 0;
};
std::vector<SectionWalkResult> walk_normal_sections(const WalkMesh& walk, const TriangleMeshInput& mesh,
                                                    const SectionWalkRequest* walks, int64_t count,
                                                    const SectionWalkOptions& options = {},
                                                    const std::atomic<bool>* cancel = nullptr);
std::vector<PseudoGeodesic> pseudo_geodesic_distances(const WalkMesh& walk, const TriangleMeshInput& mesh,
                                                      const SurfacePoint* p1, const SurfacePoint* p2, int64_t count,
                                                      const SectionWalkOptions& options = {},
                                                      const std::atomic<bool>* cancel = nullptr);

// A mesh and its walk mesh, owned together (the binding's handle). Validates the mesh:
// std::invalid_argument for negative counts, NaN/infinite positions, vertex indices out of range.
struct SurfaceWalkMesh {
  std::vector<float> positions;
  std::vector<int32_t> triangles;
  WalkMesh walk;
  TriangleMeshInput input() const {
    return {positions.data(), int32_t(positions.size() / 3), triangles.data(), int32_t(triangles.size() / 3)};
  }
};
SurfaceWalkMesh build_surface_walk_mesh(const TriangleMeshInput& mesh, const std::atomic<bool>* cancel = nullptr);

}  // namespace texsynth
