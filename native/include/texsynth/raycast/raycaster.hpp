// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Ray casting and radius queries on a polygon mesh, for interactive brushes (comb tool, clicks).
// Polygons are fan-triangulated into an Embree BVH built once in the constructor; the caster owns
// copies of everything it needs, so the caller's arrays may go away. Rebuild when the mesh changes.
//
// Queries are read-only and thread-safe; batched casts run in parallel and each ray's result
// depends only on that ray (identical whatever the thread count).
#include <cstdint>
#include <memory>
#include <vector>

#include "texsynth/mesh/poly_mesh.hpp"

namespace texsynth {

struct RayHit {
  int32_t face = -1;                 // polygon index, -1 = miss
  int32_t vertices[3] = {-1, -1, -1};  // vertex ids of the hit fan triangle
  float barycentrics[3] = {0, 0, 0};   // weights of those vertices at the hit point (sum 1)
  float distance = 0;                  // ray parameter t (in units of |direction|)
};

class RayCaster {
 public:
  // Validates the mesh (finite positions within +-1e18, corner/polygon ranges) and builds the BVH.
  // Throws std::invalid_argument on bad input, std::runtime_error if Embree fails.
  explicit RayCaster(const PolyMeshInput& mesh);
  ~RayCaster();
  RayCaster(const RayCaster&) = delete;
  RayCaster& operator=(const RayCaster&) = delete;

  int32_t num_vertices() const;
  int32_t num_polys() const;
  int64_t num_triangles() const;

  // Nearest hit of each ray origin + t·direction, t in [t_near, t_far]. Non-finite inputs or
  // components beyond +-1e18 throw (Embree would abort on them);
  // zero directions miss.
  std::vector<RayHit> cast(const float* origins, const float* directions, int64_t count, float t_near = 0.f,
                           float t_far = 1e30f) const;

  // Vertices within `radius` of `point` (Euclidean), ascending vertex id, with their distances.
  void vertices_within(const float point[3], float radius, std::vector<int32_t>& ids,
                       std::vector<float>& distances) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace texsynth
