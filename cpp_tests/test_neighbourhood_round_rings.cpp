// SPDX-License-Identifier: GPL-3.0-or-later
// Round neighbourhoods: ring points checked against analytic positions (plane: exact distance m·r at
// the template angle from the first edge; sphere: great-circle distance), against walls (border,
// hole, non-manifold fin, zero-area faces, thin sheet rim, facing limit) and for determinism.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstring>
#include <functional>
#include <future>
#include <limits>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "mesh_fixtures.hpp"
#include "neighbourhood_fixtures.hpp"
#include "texsynth/common/errors.hpp"
#include "texsynth/neighbourhood/round_rings.hpp"

using ring_fixtures::Points;
using ring_fixtures::TriMesh;
using texsynth::RingPoint;
using texsynth::RoundRings;
using texsynth::RoundRingsParams;
using P3 = std::array<double, 3>;

namespace {

constexpr double kPi = 3.14159265358979323846;

P3 sub(P3 a, P3 b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
double dotp(P3 a, P3 b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
double len(P3 a) { return std::sqrt(dotp(a, a)); }
P3 unit(P3 a) {
  double l = len(a);
  return {a[0] / l, a[1] / l, a[2] / l};
}
P3 crossp(P3 a, P3 b) { return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]}; }

RoundRings build(const TriMesh& m, const Points& p, int rings = 4, double facing = 75.0) {
  RoundRingsParams params;
  params.rings = rings;
  params.facing_limit_degrees = facing;
  return texsynth::build_round_rings(m.input(), p.input(), params);
}

P3 centre(const TriMesh& m, const Points& p, int32_t i) {
  return m.point(p.triangle[i], p.barycentric[2 * i], p.barycentric[2 * i + 1]);
}

// Template angle of ring m, bin a (radians, counter-clockwise).
double bin_angle(int m, int a) { return 2 * kPi * a / (8.0 * m); }

// On a z = 0 plane (normal +z): t0 is the point's triangle's first edge, normalised.
P3 plane_t0(const TriMesh& m, int32_t t) { return unit(sub(m.corner(t, 1), m.corner(t, 0))); }

// Where ring m, bin a must be on a z = 0 plane: centre + m·r·(cos θ t0 + sin θ (z × t0)).
P3 plane_target(const TriMesh& m, const Points& p, int32_t i, int ring, int a) {
  const P3 c = centre(m, p, i), t0 = plane_t0(m, p.triangle[i]), b = crossp({0, 0, 1}, t0);
  const double th = bin_angle(ring, a), d = ring * p.radius[i];
  return {c[0] + d * (std::cos(th) * t0[0] + std::sin(th) * b[0]), c[1] + d * (std::cos(th) * t0[1] + std::sin(th) * b[1]),
          0.0};
}

// A valid entry on a z = 0 plane: at distance m·r from the centre and at the template angle from t0.
void expect_on_plane_template(const TriMesh& m, const Points& p, const RoundRings& rr, int32_t i, int ring, int a) {
  const RingPoint& rp = rr.point_block(i)[texsynth::ring_offset(ring) + a];
  ASSERT_GE(rp.triangle, 0);
  const P3 v = sub(m.point(rp), centre(m, p, i));
  const P3 t0 = plane_t0(m, p.triangle[i]);
  EXPECT_NEAR(len(v), ring * p.radius[i], 2e-5) << "point " << i << " ring " << ring << " bin " << a;
  double angle = std::atan2(crossp(t0, v)[2], dotp(t0, v));
  double diff = std::remainder(angle - bin_angle(ring, a), 2 * kPi);
  EXPECT_NEAR(diff, 0.0, 2e-4) << "point " << i << " ring " << ring << " bin " << a;
}

// Every entry is either invalid (-1, zero barycentrics) or a proper point of an existing triangle,
// frames are finite unit vectors, and the invalid counts match the entries.
void expect_well_formed(const TriMesh& m, const RoundRings& rr) {
  int64_t invalid = 0;
  std::vector<int64_t> per_ring(size_t(rr.rings), 0);
  for (int32_t i = 0; i < rr.num_points; ++i) {
    for (int ring = 1; ring <= rr.rings; ++ring)
      for (int a = 0; a < texsynth::ring_bins(ring); ++a) {
        const RingPoint& rp = rr.point_block(i)[texsynth::ring_offset(ring) + a];
        if (rp.triangle < 0) {
          EXPECT_EQ(rp.triangle, -1);
          EXPECT_EQ(rp.b1 + rp.b2, 0);
          ++invalid, ++per_ring[ring - 1];
        } else {
          EXPECT_LT(rp.triangle, m.num_triangles());
          EXPECT_LE(int(rp.b1) + int(rp.b2), 65535);
        }
      }
    P3 n{rr.normal[3 * i], rr.normal[3 * i + 1], rr.normal[3 * i + 2]};
    P3 t{rr.tangent[3 * i], rr.tangent[3 * i + 1], rr.tangent[3 * i + 2]};
    EXPECT_NEAR(len(n), 1.0, 1e-5);
    EXPECT_NEAR(len(t), 1.0, 1e-5);
    EXPECT_NEAR(dotp(n, t), 0.0, 1e-5);
  }
  EXPECT_EQ(rr.invalid_count, invalid);
  EXPECT_EQ(rr.invalid_per_ring, per_ring);
  EXPECT_DOUBLE_EQ(rr.invalid_fraction(), double(invalid) / double(rr.points.size()));
}

TriMesh without_triangles(const TriMesh& m, const std::function<bool(int32_t)>& drop) {
  TriMesh out;
  out.positions = m.positions;
  for (int32_t t = 0; t < m.num_triangles(); ++t)
    if (!drop(t)) out.add_triangle(m.triangles[3 * t], m.triangles[3 * t + 1], m.triangles[3 * t + 2]);
  return out;
}

P3 centroid(const TriMesh& m, int32_t t) { return m.point(t, 1.0 / 3, 1.0 / 3); }

double segment_distance(P3 a, P3 b, P3 q) {
  const P3 ab = sub(b, a);
  double s = std::clamp(dotp(sub(q, a), ab) / dotp(ab, ab), 0.0, 1.0);
  return len(sub(q, {a[0] + s * ab[0], a[1] + s * ab[1], a[2] + s * ab[2]}));
}

bool inside_square(P3 p, double lo, double hi) { return p[0] >= lo && p[0] <= hi && p[1] >= lo && p[1] <= hi; }

}  // namespace

TEST(NeighbourhoodRoundRings, LayoutOffsetsAreRingPrefixSums) {
  int offset = 0;
  for (int m = 1; m <= texsynth::kMaxRings; ++m) {
    EXPECT_EQ(texsynth::ring_offset(m), offset);
    EXPECT_EQ(texsynth::ring_bins(m), 8 * m);
    offset += 8 * m;
    EXPECT_EQ(texsynth::ring_entries(m), offset);
  }
  // 700k points, K = 4: 80 entries × 8 B + 6 floats of frame per point.
  auto mem = texsynth::estimate_round_rings_memory(700000, 70000, 35000, 4);
  EXPECT_EQ(mem.result_bytes, int64_t(700000) * (80 * 8 + 24));
  EXPECT_GT(mem.peak_bytes, mem.result_bytes);
}

TEST(NeighbourhoodRoundRings, FlatPlaneRingPointsAtRadiusAndTemplateAngle) {
  const TriMesh mesh = ring_fixtures::plane(40, 40, 0.1, 0.4);  // ~[0, 4]²
  const double r = 0.13;                                         // K·r = 0.52: every disc below fits
  Points pts;
  Points all = ring_fixtures::random_points(mesh, 3000, r);
  for (int32_t i = 0; i < all.size(); ++i)
    if (inside_square(centre(mesh, all, i), 1.2, 2.8)) pts.add(all.triangle[i], all.barycentric[2 * i], all.barycentric[2 * i + 1], r);
  // Centres on vertices and edges: walks that start on a wall of their triangle.
  for (int32_t t = 0; t < mesh.num_triangles(); t += 37)
    if (inside_square(centroid(mesh, t), 1.2, 2.8))
      for (auto b : std::vector<std::array<double, 2>>{{0, 0}, {1, 0}, {0, 1}, {0.5, 0}, {0.5, 0.5}, {0, 0.5}})
        pts.add(t, b[0], b[1], r);
  ASSERT_GT(pts.size(), 500);
  const RoundRings rr = build(mesh, pts);
  expect_well_formed(mesh, rr);
  EXPECT_EQ(rr.invalid_count, 0);
  for (int32_t i = 0; i < pts.size(); ++i) {
    const P3 t0 = plane_t0(mesh, pts.triangle[i]);
    EXPECT_NEAR(rr.normal[3 * i + 2], 1.0, 1e-6);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(rr.tangent[3 * i + k], t0[k], 1e-6);
    for (int ring = 1; ring <= 4; ++ring)
      for (int a = 0; a < texsynth::ring_bins(ring); ++a) expect_on_plane_template(mesh, pts, rr, i, ring, a);
  }
}

TEST(NeighbourhoodRoundRings, PlaneBorderAndHoleStopWalksWithoutNaN) {
  const TriMesh full = ring_fixtures::plane(40, 40, 0.1, 0.4);  // vertices within 0.02 of the nominal grid
  const P3 hole{2, 2, 0};
  // Triangles whose centroid is within 0.5 of the hole centre go; no remaining triangle reaches closer
  // than 0.5 - 0.13 (centroid-to-corner of a jittered cell half), no removed one further than 0.63.
  const TriMesh mesh = without_triangles(full, [&](int32_t t) { return len(sub(centroid(full, t), hole)) < 0.5; });
  const double r = 0.2;
  const Points pts = ring_fixtures::random_points(mesh, 2000, r, 9);
  const RoundRings rr = build(mesh, pts);
  expect_well_formed(mesh, rr);
  int must_invalid = 0, must_valid = 0;
  for (int32_t i = 0; i < pts.size(); ++i)
    for (int ring = 1; ring <= 4; ++ring)
      for (int a = 0; a < texsynth::ring_bins(ring); ++a) {
        const P3 c = centre(mesh, pts, i), target = plane_target(mesh, pts, i, ring, a);
        const bool valid = rr.point_block(i)[texsynth::ring_offset(ring) + a].triangle >= 0;
        const double to_hole = segment_distance(c, target, hole);
        if (to_hole < 0.35 || !inside_square(target, -0.03, 4.03)) {
          ++must_invalid;
          EXPECT_FALSE(valid) << "point " << i << " ring " << ring << " bin " << a << " crosses the hole or border";
        } else if (to_hole > 0.65 && inside_square(c, 0.03, 3.97) && inside_square(target, 0.03, 3.97)) {
          ++must_valid;
          EXPECT_TRUE(valid) << "point " << i << " ring " << ring << " bin " << a;
        }
        if (valid) expect_on_plane_template(mesh, pts, rr, i, ring, a);
      }
  EXPECT_GT(must_invalid, 1000);
  EXPECT_GT(must_valid, 10000);
}

TEST(NeighbourhoodRoundRings, SphereRingPointsAtGeodesicRadius) {
  const double R = 1.0;
  const TriMesh sphere = ring_fixtures::icosphere(4, R);  // 5120 faces, edges ≈ 0.066 R
  for (double r : {R / 2 / 4, R / 10 / 4}) {              // K·r = R/2 and R/10
    const Points pts = ring_fixtures::random_points(sphere, 400, r, 21);
    const RoundRings rr = build(sphere, pts);
    expect_well_formed(sphere, rr);
    EXPECT_EQ(rr.invalid_count, 0) << "r = " << r;
    double worst = 0;
    for (int32_t i = 0; i < pts.size(); ++i) {
      const P3 c = unit(centre(sphere, pts, i));
      for (int ring = 1; ring <= 4; ++ring)
        for (int a = 0; a < texsynth::ring_bins(ring); ++a) {
          const RingPoint& rp = rr.point_block(i)[texsynth::ring_offset(ring) + a];
          ASSERT_GE(rp.triangle, 0);
          const double geodesic = R * std::acos(std::clamp(dotp(unit(sphere.point(rp)), c), -1.0, 1.0));
          worst = std::max(worst, std::fabs(geodesic / (ring * r) - 1));
        }
    }
    EXPECT_LT(worst, 0.01) << "r = " << r;  // far below 5 % (round_neighbourhoods.md, "Rings")
  }
}

TEST(NeighbourhoodRoundRings, SplitVertexMeshGivesTheWeldedRings) {
  for (const TriMesh& mesh : {ring_fixtures::plane(20, 20, 0.1, 0.4), ring_fixtures::icosphere(3, 1.0)}) {
    const Points pts = ring_fixtures::random_points(mesh, 500, 0.08, 4);
    const RoundRings welded = build(mesh, pts), split = build(ring_fixtures::split_vertices(mesh), pts);
    EXPECT_LT(welded.invalid_fraction(), 0.3);  // mostly valid, so equality below means something
    ASSERT_EQ(welded.points.size(), split.points.size());
    EXPECT_EQ(0, std::memcmp(welded.points.data(), split.points.data(), welded.points.size() * sizeof(RingPoint)));
    EXPECT_EQ(welded.normal, split.normal);
    EXPECT_EQ(welded.tangent, split.tangent);
  }
}

TEST(NeighbourhoodRoundRings, ThinSheetBackSideNeverReached) {
  const int n = 20;
  const TriMesh box = ring_fixtures::thin_box(n, 0.1, 0.001);  // 2 × 2 × 0.001, top triangles first
  const int32_t top_triangles = 2 * n * n;
  texsynth::Rng rng(17);
  Points pts;
  const double r = 0.1;  // K·r = 0.4, well under the 2 × 2 sheet
  for (int i = 0; i < 1500; ++i) {
    double b1 = rng.uniform(), b2 = rng.uniform();
    if (b1 + b2 > 1) b1 = 1 - b1, b2 = 1 - b2;
    pts.add(int32_t(rng.below(uint32_t(top_triangles))), b1, b2, r);
  }
  const RoundRings rr = build(box, pts);
  expect_well_formed(box, rr);
  int64_t valid = 0;
  for (int32_t i = 0; i < pts.size(); ++i) {
    const bool interior = inside_square(centre(box, pts, i), 0.41, 1.59);
    for (int e = 0; e < rr.entries_per_point; ++e) {
      const int32_t t = rr.point_block(i)[e].triangle;
      EXPECT_LT(t, top_triangles) << "point " << i << " reached the rim or the back";
      if (interior) {
        EXPECT_GE(t, 0) << "point " << i << ": its disc fits on the top sheet";
      }
      valid += t >= 0;
    }
  }
  EXPECT_GT(rr.invalid_count, 0);  // discs near the border are cut by the rim
  EXPECT_GT(valid, rr.invalid_count);
  // Without the facing limit the same walks fold over the 0.001 rim onto the back: the check above can fail.
  const RoundRings unlimited = build(box, pts, 4, 180.0);
  int64_t back = 0;
  for (const RingPoint& rp : unlimited.points) back += rp.triangle >= top_triangles;
  EXPECT_GT(back, 100);
}

TEST(NeighbourhoodRoundRings, NonManifoldFinStopsWalks) {
  TriMesh mesh = ring_fixtures::plane(20, 20, 0.1, 0.0);  // [0, 2]², grid line x = 1 is vertex column 10
  const int32_t plane_triangles = mesh.num_triangles();
  auto id = [](int x, int y) { return int32_t(y * 21 + x); };
  std::vector<int32_t> top;
  for (int j = 0; j <= 20; ++j) top.push_back(mesh.add_vertex(1.0, 0.1 * j, 0.5));
  for (int j = 0; j < 20; ++j) {  // a vertical fin on x = 1: those edges get 3 triangles
    mesh.add_triangle(id(10, j), id(10, j + 1), top[j + 1]);
    mesh.add_triangle(id(10, j), top[j + 1], top[j]);
  }
  const double r = 0.08;
  Points all = ring_fixtures::random_points(mesh, 3000, r, 8), pts;
  for (int32_t i = 0; i < all.size(); ++i)
    if (all.triangle[i] < plane_triangles) pts.add(all.triangle[i], all.barycentric[2 * i], all.barycentric[2 * i + 1], r);
  const RoundRings rr = build(mesh, pts);
  expect_well_formed(mesh, rr);
  int must_invalid = 0, must_valid = 0;
  for (int32_t i = 0; i < pts.size(); ++i)
    for (int ring = 1; ring <= 4; ++ring)
      for (int a = 0; a < texsynth::ring_bins(ring); ++a) {
        const P3 c = centre(mesh, pts, i), target = plane_target(mesh, pts, i, ring, a);
        const bool valid = rr.point_block(i)[texsynth::ring_offset(ring) + a].triangle >= 0;
        const double lo = std::min(c[0], target[0]), hi = std::max(c[0], target[0]);
        if (lo < 1 - 1e-3 && hi > 1 + 1e-3) {
          ++must_invalid;
          EXPECT_FALSE(valid) << "point " << i << " ring " << ring << " bin " << a << " crosses the fin";
        } else if ((hi < 1 - 1e-3 || lo > 1 + 1e-3) && inside_square(target, 1e-3, 2 - 1e-3)) {
          ++must_valid;
          EXPECT_TRUE(valid) << "point " << i << " ring " << ring << " bin " << a;
        }
        if (valid) expect_on_plane_template(mesh, pts, rr, i, ring, a);
      }
  EXPECT_GT(must_invalid, 1000);
  EXPECT_GT(must_valid, 10000);
}

TEST(NeighbourhoodRoundRings, ZeroAreaTrianglesAreWalls) {
  TriMesh mesh = ring_fixtures::plane(10, 10, 0.1, 0.0);
  auto id = [](int x, int y) { return int32_t(y * 11 + x); };
  // Vertex (5,5) onto (6,5): the two triangles on that edge get zero area (and weld to a 4-triangle edge).
  for (int k = 0; k < 3; ++k) mesh.positions[3 * id(5, 5) + k] = mesh.positions[3 * id(6, 5) + k];
  std::vector<int32_t> degenerate;
  for (int32_t t = 0; t < mesh.num_triangles(); ++t) {
    const P3 e = crossp(sub(mesh.corner(t, 1), mesh.corner(t, 0)), sub(mesh.corner(t, 2), mesh.corner(t, 0)));
    if (len(e) == 0) degenerate.push_back(t);
  }
  ASSERT_EQ(degenerate.size(), 2u);
  const double r = 0.05;
  Points pts = ring_fixtures::random_points(mesh, 1500, r, 12);
  for (int32_t t : degenerate) pts.add(t, 0.3, 0.3, r);
  const RoundRings rr = build(mesh, pts);
  expect_well_formed(mesh, rr);
  int64_t near_invalid = 0;
  for (int32_t i = 0; i < pts.size(); ++i) {
    const bool in_degenerate = i >= pts.size() - 2;
    const P3 c = centre(mesh, pts, i);
    for (int ring = 1; ring <= 4; ++ring)
      for (int a = 0; a < texsynth::ring_bins(ring); ++a) {
        const RingPoint& rp = rr.point_block(i)[texsynth::ring_offset(ring) + a];
        if (in_degenerate) {
          EXPECT_EQ(rp.triangle, -1);
          continue;
        }
        for (int32_t t : degenerate) EXPECT_NE(rp.triangle, t);
        const P3 target = plane_target(mesh, pts, i, ring, a);
        if (rp.triangle >= 0) expect_on_plane_template(mesh, pts, rr, i, ring, a);
        // Far from the collapsed edge (0.6, 0.5) and from the border: nothing may stop the walk.
        if (segment_distance(c, target, {0.6, 0.5, 0}) > 0.25 && inside_square(c, 1e-3, 1 - 1e-3) &&
            inside_square(target, 1e-3, 1 - 1e-3)) {
          EXPECT_GE(rp.triangle, 0) << "point " << i << " ring " << ring << " bin " << a;
        }
        near_invalid += rp.triangle < 0 && inside_square(target, 0.01, 0.99);
      }
  }
  EXPECT_GT(near_invalid, 0);  // some interior walks did stop at the zero-area wall
}

TEST(NeighbourhoodRoundRings, SmallSphereStopsAtFacingLimit) {
  const TriMesh sphere = ring_fixtures::icosphere(3, 0.1);
  // r > R: ring 1 would be 2 rad (115°) round the sphere, past the 75° facing limit.
  const RoundRings far = build(sphere, ring_fixtures::random_points(sphere, 300, 0.2, 2));
  expect_well_formed(sphere, far);
  EXPECT_EQ(far.invalid_fraction(), 1.0);
  // r = R: ring 1 at 1 rad (57°) is reachable, ring 2 at 2 rad is not.
  const Points pts = ring_fixtures::random_points(sphere, 300, 0.1, 3);
  const RoundRings rr = build(sphere, pts);
  expect_well_formed(sphere, rr);
  EXPECT_EQ(rr.invalid_per_ring[0], 0);
  for (int ring = 2; ring <= 4; ++ring) EXPECT_EQ(rr.invalid_per_ring[ring - 1], int64_t(pts.size()) * 8 * ring);
  // No facing limit: walks may circle the sphere; they must stay well-formed.
  expect_well_formed(sphere, build(sphere, pts, 4, 180.0));
}

TEST(NeighbourhoodRoundRings, RejectsBadInput) {
  const TriMesh mesh = ring_fixtures::plane(3, 3, 1.0, 0.0);
  const Points good = ring_fixtures::random_points(mesh, 10, 0.2);
  auto error = [&](const TriMesh& m, const Points& p, RoundRingsParams params = {}) -> std::string {
    try {
      texsynth::build_round_rings(m.input(), p.input(), params);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_EQ(error(mesh, good), "");
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  TriMesh bad = mesh;
  bad.positions[7] = nan;
  EXPECT_NE(error(bad, good).find("vertex 2"), std::string::npos);
  bad = mesh;
  bad.triangles[5] = mesh.num_vertices();
  EXPECT_NE(error(bad, good).find("triangle 1"), std::string::npos);
  for (int32_t t : {-1, mesh.num_triangles()}) {
    Points p = good;
    p.triangle[3] = t;
    EXPECT_NE(error(mesh, p).find("point 3"), std::string::npos) << t;
  }
  for (auto b : std::vector<std::array<float, 2>>{{-0.1f, 0.5f}, {0.7f, 0.6f}, {nan, 0.1f}, {0.1f, inf}}) {
    Points p = good;
    p.barycentric[4] = b[0], p.barycentric[5] = b[1];
    EXPECT_NE(error(mesh, p).find("barycentrics of point 2"), std::string::npos) << b[0] << " " << b[1];
  }
  for (float r : {0.f, -1.f, nan, inf}) {
    Points p = good;
    p.radius[1] = r;
    EXPECT_NE(error(mesh, p).find("radius of point 1"), std::string::npos) << r;
  }
  for (int k : {0, 7, -1}) {
    RoundRingsParams params;
    params.rings = k;
    EXPECT_NE(error(mesh, good, params).find("rings"), std::string::npos) << k;
  }
  for (double f : {0.0, -5.0, 181.0, double(nan)}) {
    RoundRingsParams params;
    params.facing_limit_degrees = f;
    EXPECT_NE(error(mesh, good, params).find("facing_limit"), std::string::npos) << f;
  }
  RoundRingsParams params;
  params.max_steps = 0;
  EXPECT_NE(error(mesh, good, params).find("max_steps"), std::string::npos);
  params = {};
  params.max_megabytes = 1e-3;  // 10 points × 664 B > 1 kB
  const std::string msg = error(mesh, good, params);
  EXPECT_NE(msg.find("MB"), std::string::npos) << msg;
  // Slightly outside (within 1e-4) is a rounding error, accepted and clamped.
  Points p = good;
  p.barycentric[0] = -5e-5f, p.barycentric[1] = 1.00004f;
  EXPECT_EQ(error(mesh, p), "");
}

TEST(NeighbourhoodRoundRings, IdenticalBytesForOneAndTwoThreads) {
  fixtures::TestMesh noisy = fixtures::uv_sphere(60, 80, 1.0, 0.02);  // triangles only when noisy
  TriMesh mesh;
  mesh.positions = noisy.positions;
  mesh.triangles = noisy.corner_verts;
  const Points pts = ring_fixtures::random_points(mesh, 20000, 0.04, 6);
  RoundRings one, two;
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
    one = build(mesh, pts);
  }
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
    two = build(mesh, pts);
  }
  ASSERT_EQ(one.points.size(), two.points.size());
  EXPECT_EQ(0, std::memcmp(one.points.data(), two.points.data(), one.points.size() * sizeof(RingPoint)));
  EXPECT_EQ(one.normal, two.normal);
  EXPECT_EQ(one.tangent, two.tangent);
  EXPECT_EQ(one.invalid_per_ring, two.invalid_per_ring);
}

TEST(NeighbourhoodRoundRings, DirectionAngleMeasuresFromTangentCounterClockwise) {
  const TriMesh sphere = ring_fixtures::icosphere(3, 1.0);
  const Points pts = ring_fixtures::random_points(sphere, 50, 0.1, 7);
  const RoundRings rr = build(sphere, pts);
  for (int32_t i = 0; i < pts.size(); ++i) {
    const P3 n{rr.normal[3 * i], rr.normal[3 * i + 1], rr.normal[3 * i + 2]};
    const P3 t{rr.tangent[3 * i], rr.tangent[3 * i + 1], rr.tangent[3 * i + 2]};
    const P3 b = crossp(n, t);
    // Outward: the smooth normal of a sphere points away from its centre.
    EXPECT_GT(dotp(n, unit(centre(sphere, pts, i))), 0.99);
    for (double deg : {30.0, -30.0, 135.0}) {
      const double th = deg * kPi / 180;
      // A normal component must not matter: only the tangent-plane projection counts.
      float dir[3];
      for (int k = 0; k < 3; ++k) dir[k] = float(2 * (std::cos(th) * t[k] + std::sin(th) * b[k]) + 0.7 * n[k]);
      bool defined = false;
      const float got = texsynth::direction_angle(rr, i, dir, &defined);
      EXPECT_TRUE(defined);
      const double want = deg < 0 ? th + 2 * kPi : th;
      EXPECT_NEAR(got, want, 1e-5) << "point " << i << " at " << deg << " degrees";
    }
    float along_n[3] = {float(n[0]), float(n[1]), float(n[2])}, zero[3] = {0, 0, 0};
    const float nanv = std::numeric_limits<float>::quiet_NaN();
    float nan_dir[3] = {nanv, 0, 0};
    for (float* d : {along_n, zero, nan_dir}) {
      bool defined = true;
      EXPECT_EQ(texsynth::direction_angle(rr, i, d, &defined), 0.f);
      EXPECT_FALSE(defined);
    }
  }
  float d[3] = {1, 0, 0};
  EXPECT_THROW(texsynth::direction_angle(rr, pts.size(), d), std::invalid_argument);
}

TEST(NeighbourhoodRoundRings, RingsDependOnGeometryOnlyNotOnPlacement) {
  // A rigid rotation of the whole mesh moves every ring point with it: t0 comes from the mesh, not
  // from world axes (and no direction input exists to depend on).
  const TriMesh sphere = ring_fixtures::icosphere(3, 1.0);
  const double c = std::cos(0.7), s = std::sin(0.7);  // about (1, 1, 1)/√3
  const P3 k = unit({1, 1, 1});
  auto rotate = [&](P3 v) {
    const P3 kv = crossp(k, v);
    const double kd = dotp(k, v);
    return P3{v[0] * c + kv[0] * s + k[0] * kd * (1 - c), v[1] * c + kv[1] * s + k[1] * kd * (1 - c),
              v[2] * c + kv[2] * s + k[2] * kd * (1 - c)};
  };
  TriMesh turned = sphere;
  for (int32_t v = 0; v < sphere.num_vertices(); ++v) {
    const P3 p = rotate(sphere.vertex(v));
    for (int j = 0; j < 3; ++j) turned.positions[3 * v + j] = float(p[j]);
  }
  const Points pts = ring_fixtures::random_points(sphere, 200, 0.06, 13);
  const RoundRings a = build(sphere, pts), b = build(turned, pts);
  EXPECT_EQ(a.invalid_count, 0);
  EXPECT_EQ(b.invalid_count, 0);
  for (int32_t i = 0; i < pts.size(); ++i)
    for (int e = 0; e < a.entries_per_point; ++e) {
      const P3 pa = rotate(sphere.point(a.point_block(i)[e])), pb = turned.point(b.point_block(i)[e]);
      EXPECT_LT(len(sub(pa, pb)), 1e-5) << "point " << i << " entry " << e;
    }
}

TEST(NeighbourhoodRoundRings, RingSampleBracketsTheAngle) {
  // Compared as a position on the ring (bin0 + weight, modulo the bin count), so an angle that lands
  // a float rounding below a bin may report (previous bin, weight ≈ 1).
  auto check = [](int ring, double phi, double position) {
    const int bins = 8 * ring;
    const texsynth::RingSample s = texsynth::ring_sample(ring, float(phi));
    EXPECT_GE(s.bin0, 0);
    EXPECT_LT(s.bin0, bins);
    EXPECT_EQ(s.bin1, (s.bin0 + 1) % bins);
    EXPECT_GE(s.weight, 0.f);
    EXPECT_LT(s.weight, 1.f);
    EXPECT_NEAR(std::remainder(s.bin0 + s.weight - position, bins), 0.0, 1e-4) << ring << " " << phi;
  };
  const double step2 = 2 * kPi / 16;  // ring 2: 16 bins
  check(2, 3.25 * step2, 3.25);
  check(2, -0.5 * step2, 15.5);  // wraps below zero
  check(2, 15.75 * step2, 15.75);
  check(2, 16 * step2 + 2.5 * step2, 2.5);  // one full turn further
  check(1, 0.0, 0.0);
  check(3, 10.5 * (2 * kPi / 24), 10.5);
  // Exact bins where the arithmetic is exact.
  texsynth::RingSample s = texsynth::ring_sample(2, float(3.25 * step2));
  EXPECT_EQ(s.bin0, 3);
  EXPECT_EQ(s.bin1, 4);
  s = texsynth::ring_sample(2, float(-0.5 * step2));
  EXPECT_EQ(s.bin0, 15);
  EXPECT_EQ(s.bin1, 0);
  s = texsynth::ring_sample(4, std::numeric_limits<float>::quiet_NaN());
  EXPECT_EQ(s.bin0, 0);
  EXPECT_EQ(s.weight, 0.f);
  EXPECT_THROW(texsynth::ring_sample(0, 0.f), std::invalid_argument);
  EXPECT_THROW(texsynth::ring_sample(7, 0.f), std::invalid_argument);
}

TEST(NeighbourhoodRoundRings, RaisedCancelFlagStops) {
  const TriMesh mesh = ring_fixtures::plane(10, 10, 0.1, 0.2);
  const Points pts = ring_fixtures::random_points(mesh, 100, 0.05);
  std::atomic<bool> flag{true};
  RoundRingsParams params;
  params.cancel = &flag;
  EXPECT_THROW(texsynth::build_round_rings(mesh.input(), pts.input(), params), texsynth::Cancelled);
}

TEST(NeighbourhoodRoundRings, FlagRaisedMidRunStops) {
  const TriMesh sphere = ring_fixtures::icosphere(4, 1.0);
  const Points pts = ring_fixtures::random_points(sphere, 100000, 0.01, 3);  // a few hundred ms of walks
  std::atomic<bool> flag{false};
  RoundRingsParams params;
  params.cancel = &flag;
  auto running = std::async(std::launch::async, [&] { texsynth::build_round_rings(sphere.input(), pts.input(), params); });
  std::this_thread::sleep_for(std::chrono::milliseconds(2));
  flag.store(true);
  EXPECT_THROW(running.get(), texsynth::Cancelled);
}
