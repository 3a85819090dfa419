// SPDX-License-Identifier: GPL-3.0-or-later
// Brush and field-preset geometry: RayCaster (Embree BVH, ray casts, radius queries) and
// principal_curvature_directions on fuzzed meshes with hostile rays, points, radii and parameters.
// Each call must either throw std::invalid_argument or return results that keep their contract.
#include <cmath>

#include "fuzz_meshes.hpp"
#include "texsynth/field/curvature.hpp"
#include "texsynth/mesh/mesh.hpp"
#include "texsynth/raycast/raycaster.hpp"

namespace {

void check_raycaster(FuzzedDataProvider& in, const fuzz::FuzzMesh& fuzz_mesh) {
  std::unique_ptr<texsynth::RayCaster> caster;
  try {
    caster = std::make_unique<texsynth::RayCaster>(fuzz_mesh.input());
  } catch (const std::invalid_argument&) {
    return;
  }
  const int32_t nv = caster->num_vertices(), np = caster->num_polys();
  const int64_t count = in.ConsumeIntegralInRange<int64_t>(0, 8);
  std::vector<float> origins(size_t(count) * 3), directions(size_t(count) * 3);
  for (float& x : origins) x = fuzz::hostile_float(in, -5, 5);
  for (float& x : directions) x = fuzz::hostile_float(in, -1, 1);
  const float t_near = fuzz::hostile_float(in, 0, 2), t_far = fuzz::hostile_float(in, 0, 100);
  try {
    const std::vector<texsynth::RayHit> hits = caster->cast(origins.data(), directions.data(), count, t_near, t_far);
    fuzz::require(hits.size() == size_t(count), "one hit record per ray");
    for (const texsynth::RayHit& hit : hits) {
      if (hit.face < 0) continue;
      fuzz::require(hit.face < np, "hit polygon in range");
      fuzz::require(hit.distance >= t_near && hit.distance <= t_far, "hit distance within [t_near, t_far]");
      float sum = 0.f;
      for (int k = 0; k < 3; ++k) {
        fuzz::require(hit.vertices[k] >= 0 && hit.vertices[k] < nv, "hit vertices in range");
        fuzz::require(std::isfinite(hit.barycentrics[k]), "finite barycentrics");
        sum += hit.barycentrics[k];
      }
      fuzz::require(std::fabs(sum - 1.f) < 1e-3f, "barycentrics sum to 1");
    }
  } catch (const std::invalid_argument&) {
  }
  const float point[3] = {fuzz::hostile_float(in, -5, 5), fuzz::hostile_float(in, -5, 5),
                          fuzz::hostile_float(in, -5, 5)};
  const float radius = fuzz::hostile_float(in, 0, 5);
  std::vector<int32_t> ids;
  std::vector<float> distances;
  try {
    caster->vertices_within(point, radius, ids, distances);
    fuzz::require(ids.size() == distances.size(), "one distance per vertex");
    for (size_t i = 0; i < ids.size(); ++i) {
      fuzz::require(ids[i] >= 0 && ids[i] < nv, "vertex id in range");
      fuzz::require(i == 0 || ids[i - 1] < ids[i], "ascending vertex ids");
      fuzz::require(std::isfinite(distances[i]) && distances[i] <= radius * (1 + 1e-5f) + 1e-6f, "within radius");
    }
  } catch (const std::invalid_argument&) {
  }
}

void check_curvature(FuzzedDataProvider& in, const fuzz::FuzzMesh& fuzz_mesh) {
  texsynth::CurvatureParams params;
  params.smoothing_rings = in.ConsumeIntegralInRange<int>(-2, 12);
  params.anisotropy_threshold = fuzz::hostile_double(in, 0, 1.2);
  texsynth::Mesh mesh;
  texsynth::CurvatureResult result;
  try {
    mesh = texsynth::build_mesh(fuzz_mesh.input());
    result = texsynth::principal_curvature_directions(mesh, params);
  } catch (const std::invalid_argument&) {
    return;
  }
  fuzz::require(result.min_direction.size() == size_t(mesh.num_vertices) * 3, "directions sized");
  fuzz::require(result.curvatures.size() == size_t(mesh.num_vertices) * 2, "curvatures sized");
  for (float k : result.curvatures) fuzz::require(std::isfinite(k), "finite curvatures");
  for (int32_t v = 0; v < mesh.num_vertices; ++v) {
    const float* d = &result.min_direction[size_t(v) * 3];
    const double length = std::sqrt(double(d[0]) * d[0] + double(d[1]) * d[1] + double(d[2]) * d[2]);
    fuzz::require(std::isfinite(length) && (length == 0 || std::fabs(length - 1) < 1e-3), "unit or zero direction");
    fuzz::require(std::fabs(result.curvatures[2 * v]) <= std::fabs(result.curvatures[2 * v + 1]) * (1 + 1e-5) + 1e-12,
                  "|k_flat| <= |k_steep|");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  FuzzedDataProvider in(data, size);
  const fuzz::FuzzMesh mesh = fuzz::any_mesh(in);
  if (in.ConsumeBool())
    check_raycaster(in, mesh);
  else
    check_curvature(in, mesh);
  return 0;
}
