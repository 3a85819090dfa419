// SPDX-License-Identifier: GPL-3.0-or-later
// RayCaster against an independent brute-force ray/triangle test (Möller–Trumbore in double)
// and a brute-force radius scan.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "mesh_fixtures.hpp"
#include "texsynth/common/rng.hpp"
#include "texsynth/raycast/raycaster.hpp"

namespace {

using fixtures::TestMesh;

struct BruteHit {
  int32_t face = -1;
  double t = std::numeric_limits<double>::infinity();
  double point[3] = {0, 0, 0};
};

// Nearest hit over every fan triangle of every polygon.
BruteHit brute_force(const TestMesh& m, const double o[3], const double d[3]) {
  BruteHit best;
  auto P = [&](int32_t v, int a) { return double(m.positions[3 * size_t(v) + a]); };
  for (size_t p = 0; p < m.poly_starts.size(); ++p) {
    const int32_t* cv = &m.corner_verts[m.poly_starts[p]];
    for (int32_t k = 1; k + 1 < m.poly_sizes[p]; ++k) {
      double e1[3], e2[3], s[3], h[3], q[3];
      for (int a = 0; a < 3; ++a) e1[a] = P(cv[k], a) - P(cv[0], a), e2[a] = P(cv[k + 1], a) - P(cv[0], a), s[a] = o[a] - P(cv[0], a);
      h[0] = d[1] * e2[2] - d[2] * e2[1], h[1] = d[2] * e2[0] - d[0] * e2[2], h[2] = d[0] * e2[1] - d[1] * e2[0];
      double det = e1[0] * h[0] + e1[1] * h[1] + e1[2] * h[2];
      if (std::fabs(det) < 1e-15) continue;
      double u = (s[0] * h[0] + s[1] * h[1] + s[2] * h[2]) / det;
      q[0] = s[1] * e1[2] - s[2] * e1[1], q[1] = s[2] * e1[0] - s[0] * e1[2], q[2] = s[0] * e1[1] - s[1] * e1[0];
      double v = (d[0] * q[0] + d[1] * q[1] + d[2] * q[2]) / det;
      double t = (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) / det;
      if (u < 0 || v < 0 || u + v > 1 || t < 0 || t >= best.t) continue;
      best.face = int32_t(p), best.t = t;
      for (int a = 0; a < 3; ++a) best.point[a] = o[a] + t * d[a];
    }
  }
  return best;
}

TEST(Raycast, MatchesBruteForceOnNoisySphere) {
  TestMesh m = fixtures::uv_sphere(24, 32, 1.0, 0.05);  // triangles, irregular
  texsynth::RayCaster caster(m.input());
  EXPECT_EQ(caster.num_triangles(), int64_t(m.poly_starts.size()));
  texsynth::Rng rng(5);
  const int n = 2000;
  std::vector<float> origins(3 * n), directions(3 * n);
  for (int i = 0; i < n; ++i) {
    // From a shell of radius 3 toward a random point inside radius 1.2: some miss, most hit.
    double o[3], target[3];
    for (int a = 0; a < 3; ++a) o[a] = 2 * rng.uniform() - 1, target[a] = 2.4 * rng.uniform() - 1.2;
    double len = std::sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2]) + 1e-9;
    for (int a = 0; a < 3; ++a) {
      origins[3 * i + a] = float(3 * o[a] / len);
      directions[3 * i + a] = float(target[a] - origins[3 * i + a]);
    }
  }
  std::vector<texsynth::RayHit> hits = caster.cast(origins.data(), directions.data(), n);
  int agree = 0, hit_count = 0, ambiguous = 0;
  for (int i = 0; i < n; ++i) {
    double o[3], d[3];
    for (int a = 0; a < 3; ++a) o[a] = origins[3 * i + a], d[a] = directions[3 * i + a];
    BruteHit want = brute_force(m, o, d);
    const texsynth::RayHit& got = hits[i];
    if (want.face < 0) {
      if (got.face >= 0) ++ambiguous;  // grazing rays may go either way; checked below
      continue;
    }
    ++hit_count;
    ASSERT_GE(got.face, 0) << "ray " << i << " missed, brute force hit face " << want.face;
    EXPECT_NEAR(got.distance, want.t, 1e-4 * (1 + want.t)) << "ray " << i;
    // Reconstructed hit point from barycentrics must equal the brute-force point.
    double p[3] = {0, 0, 0};
    for (int k = 0; k < 3; ++k)
      for (int a = 0; a < 3; ++a) p[a] += got.barycentrics[k] * m.positions[3 * size_t(got.vertices[k]) + a];
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(p[a], want.point[a], 1e-4);
    agree += got.face == want.face;
  }
  EXPECT_GT(hit_count, n / 3);
  EXPECT_LE(ambiguous, 2);
  EXPECT_GE(agree, hit_count - 2);  // only rays through shared edges may pick the neighbour
}

TEST(Raycast, PolygonsFanTriangulatedAndMissesReported) {
  TestMesh m = fixtures::grid(4, 3, 0.5, false);  // quads on z = 0
  texsynth::RayCaster caster(m.input());
  EXPECT_EQ(caster.num_triangles(), 2 * 12);
  const float origins[] = {0.6f, 0.3f, 1.f, 0.6f, 0.3f, 1.f, 5.f, 5.f, 1.f, 0.6f, 0.3f, -1.f, 0.6f, 0.3f, 1.f};
  const float dirs[] = {0, 0, -1.f, 0, 0, 1.f, 0, 0, -1.f, 0, 0, 2.f, 0, 0, 0};
  auto hits = caster.cast(origins, dirs, 5);
  EXPECT_EQ(hits[0].face, 1);  // x in [0.5, 1), y in [0, 0.5): quad 1
  EXPECT_NEAR(hits[0].distance, 1.f, 1e-6);
  EXPECT_EQ(hits[1].face, -1);  // pointing away
  EXPECT_EQ(hits[2].face, -1);  // outside
  EXPECT_EQ(hits[3].face, 1);   // from below, t in units of |direction|
  EXPECT_NEAR(hits[3].distance, 0.5f, 1e-6);
  EXPECT_EQ(hits[4].face, -1);  // zero direction
  // t_far shorter than the hit distance: miss.
  auto short_hits = caster.cast(origins, dirs, 1, 0.f, 0.5f);
  EXPECT_EQ(short_hits[0].face, -1);
}

TEST(Raycast, VerticesWithinMatchesBruteForce) {
  TestMesh m = fixtures::uv_sphere(40, 60, 2.0, 0.03);
  texsynth::RayCaster caster(m.input());
  texsynth::Rng rng(9);
  std::vector<int32_t> ids;
  std::vector<float> dist;
  for (int q = 0; q < 60; ++q) {
    float p[3];
    for (int a = 0; a < 3; ++a) p[a] = float(5 * rng.uniform() - 2.5);
    float radius = float(q < 50 ? 0.6 * rng.uniform() : 3 + 3 * rng.uniform());  // small and huge brushes
    caster.vertices_within(p, radius, ids, dist);
    std::vector<int32_t> want;
    for (int32_t v = 0; v < m.num_vertices(); ++v) {
      double d2 = 0;
      for (int a = 0; a < 3; ++a) d2 += std::pow(double(m.positions[3 * size_t(v) + a]) - p[a], 2);
      if (d2 <= double(radius) * radius) want.push_back(v);
    }
    ASSERT_EQ(ids, want) << "query " << q;
    for (size_t i = 0; i < ids.size(); ++i) {
      double d2 = 0;
      for (int a = 0; a < 3; ++a) d2 += std::pow(double(m.positions[3 * size_t(ids[i]) + a]) - p[a], 2);
      EXPECT_NEAR(dist[i], std::sqrt(d2), 1e-5);
    }
  }
}

TEST(Raycast, RejectsBadInput) {
  TestMesh m = fixtures::grid(2, 2, 1.0, true);
  TestMesh bad = m;
  bad.positions[4] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(texsynth::RayCaster{bad.input()}, std::invalid_argument);
  bad = m;
  bad.corner_verts[2] = 99;
  EXPECT_THROW(texsynth::RayCaster{bad.input()}, std::invalid_argument);
  bad = m;
  bad.poly_sizes[0] = 2;
  EXPECT_THROW(texsynth::RayCaster{bad.input()}, std::invalid_argument);
  bad = m;
  bad.poly_starts.back() = int32_t(bad.corner_verts.size()) - 1;
  EXPECT_THROW(texsynth::RayCaster{bad.input()}, std::invalid_argument);

  texsynth::RayCaster caster(m.input());
  const float o[] = {0, 0, std::numeric_limits<float>::infinity()}, d[] = {0, 0, -1};
  EXPECT_THROW(caster.cast(o, d, 1), std::invalid_argument);
  const float ok[] = {0.5f, 0.5f, 1.f};
  EXPECT_THROW(caster.cast(ok, d, 1, 1.f, 0.5f), std::invalid_argument);
  // Finite but beyond Embree's valid range: Debian's Embree asserts (aborts the process) on these.
  const float far_origin[] = {0.5f, 0.5f, 1e30f}, huge_direction[] = {0.f, 0.f, -3e38f};
  EXPECT_THROW(caster.cast(far_origin, d, 1), std::invalid_argument);
  EXPECT_THROW(caster.cast(ok, huge_direction, 1), std::invalid_argument);
  bad = m;
  bad.positions[5] = 1e30f;
  EXPECT_THROW(texsynth::RayCaster{bad.input()}, std::invalid_argument);
  std::vector<int32_t> ids;
  std::vector<float> dist;
  EXPECT_THROW(caster.vertices_within(ok, -1.f, ids, dist), std::invalid_argument);
  EXPECT_THROW(caster.vertices_within(o, 1.f, ids, dist), std::invalid_argument);
}

TEST(Raycast, EmptyMeshNeverHits) {
  TestMesh m;
  m.add_vertex(0, 0, 0);
  texsynth::RayCaster caster(m.input());
  const float o[] = {0, 0, 1}, d[] = {0, 0, -1};
  EXPECT_EQ(caster.cast(o, d, 1)[0].face, -1);
  std::vector<int32_t> ids;
  std::vector<float> dist;
  caster.vertices_within(o, 2.f, ids, dist);
  EXPECT_EQ(ids, std::vector<int32_t>{0});
}

}  // namespace
