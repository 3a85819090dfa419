// SPDX-License-Identifier: GPL-3.0-or-later
// Decal geometry of texture particles (particles/decals.hpp;
// docs/algorithms/texture_particles.md, "Decals and the analysis cache"):
// areas, UV cells and shared-vertex counts worked out from the rectangles and the meshes (a big quad,
// jittered and regular grids, a sphere, a cylinder, a mesh border, a sheet folded back), same bytes at
// 1 and 2 threads, refusals and cancel.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <set>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include "neighbourhood_fixtures.hpp"
#include "texsynth/common/errors.hpp"
#include "texsynth/common/rng.hpp"
#include "texsynth/particles/decals.hpp"

namespace {

using ring_fixtures::TriMesh;
using texsynth::DecalMesh;
using texsynth::DecalParticle;
using texsynth::SurfacePoint;
using texsynth::V3;

constexpr double kPi = 3.14159265358979323846;

V3 vertex(const std::vector<float>& pos, int32_t v) { return {pos[3 * size_t(v)], pos[3 * size_t(v) + 1], pos[3 * size_t(v) + 2]}; }

using ring_fixtures::locate;

struct Scene {
  TriMesh mesh;
  texsynth::SurfaceWalkMesh s;
  explicit Scene(TriMesh m) : mesh(std::move(m)), s(texsynth::build_surface_walk_mesh(mesh.input())) {}
};

DecalParticle particle(SurfacePoint at, V3 axis, std::array<double, 4> rect,
                       std::array<double, 4> uv = {0.25, 0.5, 0.5, 0.75}) {
  DecalParticle p;
  p.anchor = at, p.axis = axis, p.rect = rect, p.uv_rect = uv;
  return p;
}

DecalMesh decals(const Scene& sc, const std::vector<DecalParticle>& ps, double offset = 0, double angle = 75) {
  texsynth::DecalOptions o;
  o.offset = offset;
  o.max_normal_angle = angle;
  return texsynth::build_decal_mesh(sc.s, ps.data(), int64_t(ps.size()), o);
}

V3 newell(const DecalMesh& d, size_t f) {
  V3 sum;
  const int32_t s = d.loop_starts[f], n = d.loop_totals[f];
  for (int32_t k = 0; k < n; ++k) {
    const V3 a = vertex(d.positions, d.corner_verts[size_t(s + k)]), b = vertex(d.positions, d.corner_verts[size_t(s + (k + 1) % n)]);
    sum = sum + texsynth::cross(a, b);
  }
  return sum;
}

double total_area(const DecalMesh& d) {
  double a = 0;
  for (size_t f = 0; f < d.loop_starts.size(); ++f) a += 0.5 * texsynth::norm(newell(d, f));
  return a;
}

// Area of the decal's projection onto the plane with unit normal n (signed by that normal).
double projected_area(const DecalMesh& d, V3 n) {
  double a = 0;
  for (size_t f = 0; f < d.loop_starts.size(); ++f) a += 0.5 * texsynth::dot(newell(d, f), n);
  return a;
}

int32_t num_vertices(const DecalMesh& d) { return int32_t(d.positions.size() / 3); }

// Corner UVs lie in the cell and reach all four of its sides exactly.
void expect_uvs_span_cell(const DecalMesh& d, std::array<double, 4> uv) {
  float s_lo = 1e9f, s_hi = -1e9f, t_lo = 1e9f, t_hi = -1e9f;
  for (size_t c = 0; c < d.corner_verts.size(); ++c) {
    s_lo = std::min(s_lo, d.corner_uvs[2 * c]), s_hi = std::max(s_hi, d.corner_uvs[2 * c]);
    t_lo = std::min(t_lo, d.corner_uvs[2 * c + 1]), t_hi = std::max(t_hi, d.corner_uvs[2 * c + 1]);
  }
  EXPECT_EQ(s_lo, float(std::min(uv[0], uv[2])));
  EXPECT_EQ(s_hi, float(std::max(uv[0], uv[2])));
  EXPECT_EQ(t_lo, float(std::min(uv[1], uv[3])));
  EXPECT_EQ(t_hi, float(std::max(uv[1], uv[3])));
}

// Distance from x to triangle (a, b, c).
double point_triangle_distance(V3 x, V3 a, V3 b, V3 c) {
  const V3 n = texsynth::cross(b - a, c - a);
  const double n2 = texsynth::dot(n, n);
  const V3 q = x - a;
  const double b1 = texsynth::dot(texsynth::cross(q, c - a), n) / n2, b2 = texsynth::dot(texsynth::cross(b - a, q), n) / n2;
  if (b1 >= 0 && b2 >= 0 && b1 + b2 <= 1) return std::fabs(texsynth::dot(q, n)) / std::sqrt(n2);
  auto seg = [&](V3 p, V3 r) {
    const V3 e = r - p;
    const double s = std::clamp(texsynth::dot(x - p, e) / texsynth::dot(e, e), 0.0, 1.0);
    return texsynth::norm(x - (p + e * s));
  };
  return std::min({seg(a, b), seg(b, c), seg(c, a)});
}

double distance_to_mesh(const TriMesh& m, V3 x) {
  double best = std::numeric_limits<double>::infinity();
  for (int32_t t = 0; t < m.num_triangles(); ++t)
    best = std::min(best, point_triangle_distance(x, vertex(m.positions, m.triangles[3 * t]),
                                                  vertex(m.positions, m.triangles[3 * t + 1]),
                                                  vertex(m.positions, m.triangles[3 * t + 2])));
  return best;
}

TriMesh quad(double half) {
  TriMesh m;
  const float h = float(half);
  m.positions = {-h, -h, 0, h, -h, 0, h, h, 0, -h, h, 0};
  m.triangles = {0, 1, 2, 0, 2, 3};
  return m;
}

TEST(ParticlesDecal, OneQuadTenTimesTheParticleShowsExactlyTheRectangle) {
  const Scene sc(quad(5.0));  // 10 x 10 against a 1 x 0.6 particle
  const double a = 30 * kPi / 180;
  const V3 axis{std::cos(a), std::sin(a), 0}, vaxis{-std::sin(a), std::cos(a), 0};
  const V3 anchor{0.2, 0.1, 0};  // the rectangle crosses the quad's diagonal
  const std::array<double, 4> rect{-0.4, -0.25, 0.6, 0.35}, uv{0.25, 0.5, 0.5, 0.75};
  const DecalMesh d = decals(sc, {particle(locate(sc.mesh, anchor), axis, rect, uv)}, 0.01);
  EXPECT_NEAR(total_area(d), 1.0 * 0.6, 1e-6);
  ASSERT_EQ(d.loop_starts.size(), 2u);     // one piece per triangle under it
  EXPECT_EQ(num_vertices(d), 6);           // 4 rectangle corners + 2 on the diagonal, shared
  expect_uvs_span_cell(d, uv);
  for (int32_t v = 0; v < num_vertices(d); ++v) {
    const V3 p = vertex(d.positions, v), q = p - anchor;
    EXPECT_NEAR(p.z, 0.01, 1e-7);
    EXPECT_GE(texsynth::dot(q, axis), rect[0] - 1e-6);
    EXPECT_LE(texsynth::dot(q, axis), rect[2] + 1e-6);
    EXPECT_GE(texsynth::dot(q, vaxis), rect[1] - 1e-6);
    EXPECT_LE(texsynth::dot(q, vaxis), rect[3] + 1e-6);
  }
  for (size_t f = 0; f < d.loop_starts.size(); ++f) EXPECT_GT(newell(d, f).z, 0) << "winding kept";
  EXPECT_EQ(d.face_particle, (std::vector<int32_t>{0, 0}));
  EXPECT_EQ(d.curved, (std::vector<uint8_t>{0}));
  EXPECT_NEAR(d.stats.min_coverage, 1.0, 1e-9);
}

TEST(ParticlesDecal, ManySmallFacesCoverTheRectangleOnTheSurface) {
  const Scene sc(ring_fixtures::plane(40, 40, 0.1, 0.6, 7));  // 4 x 4, jittered triangles
  const double a = 0.7;
  const V3 axis{std::cos(a), std::sin(a), 0}, vaxis{-std::sin(a), std::cos(a), 0};
  const V3 anchor{2.03, 1.96, 0};
  const std::array<double, 4> rect{-0.7, -0.3, 0.6, 0.4}, uv{0.1, 0.9, 0.3, 0.6};  // t flipped: allowed
  const double offset = 0.02;
  const DecalMesh d = decals(sc, {particle(locate(sc.mesh, anchor), axis, rect, uv)}, offset);
  EXPECT_NEAR(total_area(d), 1.3 * 0.7, 1e-5);
  EXPECT_GT(d.loop_starts.size(), 100u);
  expect_uvs_span_cell(d, uv);
  for (int32_t v = 0; v < num_vertices(d); ++v) EXPECT_NEAR(vertex(d.positions, v).z, offset, 1e-7);
  // Every corner's UV is the rectangle mapped onto the cell at that corner's position.
  for (size_t c = 0; c < d.corner_verts.size(); ++c) {
    const V3 q = vertex(d.positions, d.corner_verts[c]) - anchor;
    const double fu = (texsynth::dot(q, axis) - rect[0]) / (rect[2] - rect[0]);
    const double fv = (texsynth::dot(q, vaxis) - rect[1]) / (rect[3] - rect[1]);
    ASSERT_NEAR(d.corner_uvs[2 * c], uv[0] + fu * (uv[2] - uv[0]), 2e-6);
    ASSERT_NEAR(d.corner_uvs[2 * c + 1], uv[1] + fv * (uv[3] - uv[1]), 2e-6);
  }
  for (size_t f = 0; f < d.loop_starts.size(); ++f) {
    EXPECT_GE(d.loop_totals[f], 3);
    EXPECT_LE(d.loop_totals[f], 7);
    EXPECT_GT(newell(d, f).z, 0);
  }
}

// Lines of a regular triangulated grid (fixtures::grid, spacing 1): x = k, y = k, y - x = k.
TEST(ParticlesDecal, VerticesAreSharedAsOnARegularGrid) {
  const Scene sc(ring_fixtures::plane(10, 10, 1.0, 0.0));
  const double x0 = 3.3, x1 = 7.6, y0 = 4.2, y1 = 6.9;  // the rectangle in world coordinates
  const V3 anchor{5.45, 5.55, 0};
  const DecalMesh d = decals(sc, {particle(locate(sc.mesh, anchor), {1, 0, 0},
                                           {x0 - anchor.x, y0 - anchor.y, x1 - anchor.x, y1 - anchor.y})});
  // Expected: grid vertices strictly inside, crossings of each side with the three line families,
  // and the four corners (none lies on a line).
  int expected = 4;
  for (int x = 0; x <= 10; ++x)
    for (int y = 0; y <= 10; ++y) expected += x > x0 && x < x1 && y > y0 && y < y1;
  for (int k = -10; k <= 10; ++k) {
    expected += (k > y0 && k < y1) * 2;              // horizontal lines cross the sides x = x0, x1
    expected += (k > x0 && k < x1) * 2;              // vertical lines cross y = y0, y1
    expected += (x0 + k > y0 && x0 + k < y1) + (x1 + k > y0 && x1 + k < y1);  // diagonals y = x + k
    expected += (y0 - k > x0 && y0 - k < x1) + (y1 - k > x0 && y1 - k < x1);
  }
  EXPECT_EQ(expected, 38);  // worked by hand: 8 inside, 26 crossings, 4 corners
  EXPECT_EQ(num_vertices(d), expected);
  std::set<std::tuple<float, float, float>> distinct;
  for (int32_t v = 0; v < num_vertices(d); ++v)
    distinct.insert({d.positions[3 * size_t(v)], d.positions[3 * size_t(v) + 1], d.positions[3 * size_t(v) + 2]});
  EXPECT_EQ(int32_t(distinct.size()), num_vertices(d)) << "no vertex duplicated";
  EXPECT_NEAR(total_area(d), (x1 - x0) * (y1 - y0), 1e-5);
  // Euler on a disc: V - E + F = 1, E counted from the polygons' sides (interior ones twice).
  std::set<std::pair<int32_t, int32_t>> edges;
  for (size_t f = 0; f < d.loop_starts.size(); ++f)
    for (int32_t k = 0; k < d.loop_totals[f]; ++k) {
      const int32_t a = d.corner_verts[size_t(d.loop_starts[f] + k)];
      const int32_t b = d.corner_verts[size_t(d.loop_starts[f] + (k + 1) % d.loop_totals[f])];
      edges.insert({std::min(a, b), std::max(a, b)});
    }
  EXPECT_EQ(num_vertices(d) - int32_t(edges.size()) + int32_t(d.loop_starts.size()), 1);
}

TEST(ParticlesDecal, SphereDecalLiesOnTheSurfaceAndIsFlaggedCurvedWhenLarge) {
  const Scene sc(ring_fixtures::icosphere(4, 1.0));  // 5,120 faces, edges ~0.06
  const V3 dir = texsynth::normalized_or(V3{0.3, -0.5, 0.8}, V3{});
  const SurfacePoint at = locate(sc.mesh, dir);
  ASSERT_GE(at.triangle, 0);
  const V3 axis = texsynth::normalized_or(texsynth::cross(dir, V3{0, 0, 1}), V3{});
  const double small = 0.15, large = 0.45;
  const DecalMesh d = decals(sc, {particle(at, axis, {-small, -small, small, small}),
                                  particle(at, axis, {-large, -large, large, large})});
  ASSERT_EQ(d.curved.size(), 2u);
  EXPECT_EQ(d.curved[0], 0) << "R = 0.21 on a unit sphere";
  EXPECT_EQ(d.curved[1], 1) << "R = 0.64 on a unit sphere";
  DecalMesh first = decals(sc, {particle(at, axis, {-small, -small, small, small})});
  const V3 n = texsynth::smooth_normal(sc.s.walk, sc.s.input(), at);
  EXPECT_NEAR(projected_area(first, n), 4 * small * small, 1e-5);
  for (int32_t v = 0; v < num_vertices(first); ++v)
    ASSERT_LT(distance_to_mesh(sc.mesh, vertex(first.positions, v)), 1e-6) << "vertex " << v;
  expect_uvs_span_cell(first, {0.25, 0.5, 0.5, 0.75});
  // Offset along the smooth normal: every vertex moves off the surface by the offset.
  const DecalMesh lifted = decals(sc, {particle(at, axis, {-small, -small, small, small})}, 0.01);
  ASSERT_EQ(lifted.positions.size(), first.positions.size());
  for (int32_t v = 0; v < num_vertices(lifted); ++v)
    EXPECT_NEAR(texsynth::norm(vertex(lifted.positions, v) - vertex(first.positions, v)), 0.01, 1e-6);
}

TEST(ParticlesDecal, CylinderDecalsAreCurvedAroundButNotAlong) {
  const Scene sc(ring_fixtures::cylinder(96, 40, 1.0, 0.05));  // radius 1, height 2
  const SurfacePoint at = locate(sc.mesh, {std::cos(0.013), std::sin(0.013), 1.013});  // off the grid lines
  ASSERT_GE(at.triangle, 0);
  const V3 along{0, 0, 1};  // u along the axis, v = n x u around it
  const DecalMesh d = decals(sc, {particle(at, along, {-0.6, -0.05, 0.6, 0.05}),    // squash 0.04 %
                                  particle(at, along, {-0.05, -0.6, 0.05, 0.6})});  // squash 5.9 %
  EXPECT_EQ(d.curved, (std::vector<uint8_t>{0, 1}));
  const V3 n = texsynth::smooth_normal(sc.s.walk, sc.s.input(), at);
  const DecalMesh around = decals(sc, {particle(at, along, {-0.05, -0.6, 0.05, 0.6})});
  EXPECT_NEAR(projected_area(around, n), 0.1 * 1.2, 1e-5);
  for (int32_t v = 0; v < num_vertices(around); ++v) {
    const V3 p = vertex(around.positions, v);
    ASSERT_LT(distance_to_mesh(sc.mesh, p), 1e-6);
  }
}

TEST(ParticlesDecal, ParticleNearTheBorderIsClippedThere) {
  const Scene sc(ring_fixtures::plane(20, 20, 0.1, 0.0));  // [0, 2]^2
  const V3 anchor{0.1, 1.03, 0};
  const DecalMesh d = decals(sc, {particle(locate(sc.mesh, anchor), {1, 0, 0}, {-0.3, -0.3, 0.3, 0.3})});
  EXPECT_NEAR(total_area(d), 0.4 * 0.6, 1e-5);  // x in [0, 0.4] of [-0.2, 0.4]
  EXPECT_NEAR(d.stats.min_coverage, 0.4 / 0.6, 1e-6);
  for (int32_t v = 0; v < num_vertices(d); ++v) EXPECT_GE(vertex(d.positions, v).x, -1e-7);
}

// A strip folded back on itself: bottom sheet z = 0 (normal +z) for x in [0, 1], a vertical bend at
// x = 1, top sheet z = gap (normal -z) coming back over it.
TriMesh folded_sheet(int n, double gap) {
  TriMesh m;
  const double s = 1.0 / n;
  auto row = [&](double z, bool back) {
    const int32_t first = m.num_vertices();
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) m.add_vertex(back ? 1 - i * s : i * s, j * s, z);
    return first;
  };
  const int32_t bottom = row(0, false), top = row(gap, true);
  auto id = [&](int32_t base, int i, int j) { return base + j * (n + 1) + i; };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      m.add_triangle(id(bottom, i, j), id(bottom, i + 1, j), id(bottom, i + 1, j + 1));
      m.add_triangle(id(bottom, i, j), id(bottom, i + 1, j + 1), id(bottom, i, j + 1));
      // The top grid runs x backwards: the same index order faces down.
      m.add_triangle(id(top, i, j), id(top, i + 1, j), id(top, i + 1, j + 1));
      m.add_triangle(id(top, i, j), id(top, i + 1, j + 1), id(top, i, j + 1));
    }
  // The bend: bottom's x = 1 column to top's x = 1 column (top i = 0), facing +x.
  for (int j = 0; j < n; ++j) {
    const int32_t b0 = id(bottom, n, j), b1 = id(bottom, n, j + 1), t0 = id(top, 0, j), t1 = id(top, 0, j + 1);
    m.add_triangle(b0, t0, t1);
    m.add_triangle(b0, t1, b1);
  }
  return m;
}

TEST(ParticlesDecal, FoldedSheetDoesNotGetTheBackFaces) {
  const Scene sc(folded_sheet(20, 0.02));
  // The fold is walkable (no wall): the flood fill reaches the bend and stops on its normal.
  const V3 anchor{0.95, 0.52, 0};
  const SurfacePoint at = locate(sc.mesh, anchor);
  ASSERT_GE(at.triangle, 0);
  ASSERT_GT(sc.s.walk.tris[size_t(at.triangle)].normal.z, 0.99) << "anchored on the bottom sheet";
  const DecalMesh d = decals(sc, {particle(at, {1, 0, 0}, {-0.3, -0.3, 0.3, 0.3})});
  EXPECT_NEAR(total_area(d), 0.35 * 0.6, 1e-5);  // x in [0.65, 1] on the bottom sheet only
  for (int32_t v = 0; v < num_vertices(d); ++v) EXPECT_EQ(vertex(d.positions, v).z, 0.0f) << "not on the top sheet";
  EXPECT_GT(d.stats.faces_folded, 0);
  for (size_t f = 0; f < d.loop_starts.size(); ++f) EXPECT_GT(newell(d, f).z, 0);
}

// Two turns of a spiral ramp (r 0.5..1, rising 0.05 a turn): every normal within a few degrees of +z.
TriMesh spiral_ramp(int around, int across) {
  TriMesh m;
  const int steps = 2 * around;
  for (int i = 0; i <= steps; ++i)
    for (int j = 0; j <= across; ++j) {
      const double a = 2 * kPi * i / around, r = 0.5 + 0.5 * j / across;
      m.add_vertex(r * std::cos(a), r * std::sin(a), 0.05 * a / (2 * kPi));
    }
  auto id = [&](int i, int j) { return int32_t(i * (across + 1) + j); };
  for (int i = 0; i < steps; ++i)
    for (int j = 0; j < across; ++j) {
      m.add_triangle(id(i, j), id(i, j + 1), id(i + 1, j + 1));
      m.add_triangle(id(i, j), id(i + 1, j + 1), id(i + 1, j));
    }
  return m;
}

TEST(ParticlesDecal, SurfaceWindingOverItselfIsCountedAsOverlapping) {
  const Scene sc(spiral_ramp(64, 4));
  const SurfacePoint at = locate(sc.mesh, {-0.75, 0.01, 0.025});  // half way round the first turn
  ASSERT_GE(at.triangle, 0);
  ASSERT_GT(std::fabs(sc.s.walk.tris[size_t(at.triangle)].normal.z), 0.98);
  const V3 axis{1, 0, 0};
  // Around the whole annulus: the fill climbs onto the second turn, which lies over the first.
  const DecalMesh whole = decals(sc, {particle(at, axis, {-0.3, -1.05, 1.8, 1.05})});
  EXPECT_EQ(whole.stats.overlapping, 1);
  EXPECT_GT(whole.stats.mean_coverage, 0.5);
  // A particle smaller than a turn covers its rectangle once.
  const DecalMesh small = decals(sc, {particle(at, axis, {-0.2, -0.2, 0.2, 0.2})});
  EXPECT_EQ(small.stats.overlapping, 0);
  EXPECT_NEAR(small.stats.min_coverage, 1.0, 1e-6);
}

std::vector<DecalParticle> random_particles(const TriMesh& m, int count, uint64_t seed) {
  texsynth::Rng rng(seed);
  std::vector<DecalParticle> ps;
  for (int i = 0; i < count; ++i) {
    const int32_t t = int32_t(rng.below(uint32_t(m.num_triangles())));
    double b1 = rng.uniform(), b2 = rng.uniform();
    if (b1 + b2 > 1) b1 = 1 - b1, b2 = 1 - b2;
    const double h = 0.05 + 0.1 * rng.uniform();
    ps.push_back(particle({t, b1, b2}, {rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5},
                          {-h, -0.7 * h, 1.2 * h, h}, {0, 0, 0.1, 0.1}));
  }
  return ps;
}

TEST(ParticlesDecal, SameBytesAtOneAndTwoThreads) {
  const Scene sc(ring_fixtures::icosphere(4, 1.0));
  const std::vector<DecalParticle> ps = random_particles(sc.mesh, 400, 9);
  DecalMesh one, two;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    one = decals(sc, ps, 0.003);
  }
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
    two = decals(sc, ps, 0.003);
  }
  EXPECT_EQ(one.positions, two.positions);
  EXPECT_EQ(one.loop_starts, two.loop_starts);
  EXPECT_EQ(one.loop_totals, two.loop_totals);
  EXPECT_EQ(one.corner_verts, two.corner_verts);
  EXPECT_EQ(one.corner_uvs, two.corner_uvs);
  EXPECT_EQ(one.face_particle, two.face_particle);
  EXPECT_EQ(one.curved, two.curved);
  EXPECT_EQ(one.stats.empty, 0);
  // Particles in order, each one's faces together.
  EXPECT_TRUE(std::is_sorted(one.face_particle.begin(), one.face_particle.end()));
  EXPECT_EQ(one.face_particle.back(), 399);
}

template <class F>
void expect_refused(F&& f, const std::string& needle) {
  try {
    f();
    ADD_FAILURE() << "not refused: " << needle;
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

TEST(ParticlesDecal, RefusesBadInputAndStopsOnCancel) {
  const Scene sc(quad(1.0));
  const DecalParticle good = particle({0, 0.2, 0.2}, {1, 0, 0}, {-0.1, -0.1, 0.1, 0.1});
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  auto with = [&](auto change) {
    std::vector<DecalParticle> ps{good, good};
    change(ps[1]);
    return [ps, &sc] { decals(sc, ps); };
  };
  expect_refused(with([](DecalParticle& p) { p.anchor.triangle = 2; }), "particle 1");
  expect_refused(with([](DecalParticle& p) { p.anchor.triangle = -1; }), "triangle");
  expect_refused(with([&](DecalParticle& p) { p.anchor.b1 = nan; }), "barycentrics");
  expect_refused(with([](DecalParticle& p) { p.axis = {0, 0, 0}; }), "axis of particle 1");
  expect_refused(with([](DecalParticle& p) { p.axis = {0, 0, 2}; }), "along the surface normal");
  expect_refused(with([&](DecalParticle& p) { p.axis.x = nan; }), "axis");
  expect_refused(with([&](DecalParticle& p) { p.rect[2] = nan; }), "rect of particle 1");
  expect_refused(with([](DecalParticle& p) { p.rect = {-0.1, -0.1, -0.1, 0.1}; }), "empty or negative");
  expect_refused(with([](DecalParticle& p) { p.rect = {0.1, -0.1, -0.1, 0.1}; }), "empty or negative");
  expect_refused(with([](DecalParticle& p) { p.rect = {0.05, -0.1, 0.1, 0.1}; }), "does not contain the anchor");
  expect_refused(with([&](DecalParticle& p) { p.uv_rect[1] = inf; }), "uv_rect of particle 1");
  std::vector<DecalParticle> ps{good};
  expect_refused([&] { decals(sc, ps, inf); }, "offset");
  expect_refused([&] { decals(sc, ps, nan); }, "offset");
  for (double angle : {0.0, 90.0, -5.0, nan}) expect_refused([&] { decals(sc, ps, 0, angle); }, "max_normal_angle");
  expect_refused([&] { texsynth::build_decal_mesh(sc.s, nullptr, 3, {}); }, "missing particles");

  std::atomic<bool> cancel{true};
  texsynth::DecalOptions o;
  o.cancel = &cancel;
  EXPECT_THROW(texsynth::build_decal_mesh(sc.s, ps.data(), 1, o), texsynth::Cancelled);
  // Nothing at all: an empty, valid result.
  const DecalMesh none = decals(sc, {});
  EXPECT_TRUE(none.positions.empty() && none.loop_starts.empty() && none.curved.empty());
}

}  // namespace

// The source triangle and barycentrics put every corner back on its vertex (before the offset): the bake
// composites decals through them, so a corner off by more than float rounding would smear the sprite.
TEST(ParticlesDecal, SourceTrianglesAndBarycentricsReproduceTheVertices) {
  for (int shape = 0; shape < 2; ++shape) {
    const Scene sc(shape == 0 ? ring_fixtures::plane(40, 40, 0.1, 0.6, 7) : ring_fixtures::icosphere(4, 1.0));
    const V3 at_point = shape == 0 ? V3{2.03, 1.96, 0} : texsynth::normalized_or(V3{0.3, -0.5, 0.8}, V3{});
    const SurfacePoint at = locate(sc.mesh, at_point);
    ASSERT_GE(at.triangle, 0);
    const V3 axis = shape == 0 ? V3{1, 0.3, 0} : texsynth::normalized_or(texsynth::cross(at_point, V3{0, 0, 1}), V3{});
    const std::vector<DecalParticle> ps{particle(at, axis, {-0.4, -0.3, 0.35, 0.25})};
    const DecalMesh d = decals(sc, ps), lifted = decals(sc, ps, 0.01);
    ASSERT_EQ(d.face_triangle.size(), d.loop_starts.size());
    ASSERT_EQ(d.corner_barycentric.size(), 2 * d.corner_verts.size());
    EXPECT_EQ(lifted.face_triangle, d.face_triangle) << "the offset moves vertices, not their source";
    EXPECT_EQ(lifted.corner_barycentric, d.corner_barycentric);
    const int32_t num_triangles = int32_t(sc.mesh.triangles.size() / 3);
    for (size_t f = 0; f < d.loop_starts.size(); ++f) {
      const int32_t t = d.face_triangle[f];
      ASSERT_TRUE(t >= 0 && t < num_triangles);
      const int32_t* c = sc.mesh.triangles.data() + 3 * size_t(t);
      for (int32_t k = 0; k < d.loop_totals[f]; ++k) {
        const size_t corner = size_t(d.loop_starts[f] + k);
        const double b1 = d.corner_barycentric[2 * corner], b2 = d.corner_barycentric[2 * corner + 1];
        ASSERT_TRUE(b1 >= 0 && b2 >= 0 && b1 + b2 <= 1 + 1e-6) << b1 << " " << b2;
        const V3 p = vertex(sc.mesh.positions, c[0]) * (1 - b1 - b2) + vertex(sc.mesh.positions, c[1]) * b1 +
                     vertex(sc.mesh.positions, c[2]) * b2;
        const V3 q = vertex(d.positions, d.corner_verts[corner]);
        ASSERT_LT(texsynth::norm(p - q), 1e-6) << "shape " << shape << " corner " << corner;
      }
    }
    // Faces of several triangles: the polygons really come from different source triangles.
    EXPECT_GT(std::set<int32_t>(d.face_triangle.begin(), d.face_triangle.end()).size(), 5u);
  }
}

namespace {

DecalMesh stacked_decals(const Scene& sc, const std::vector<DecalParticle>& ps, double offset, double step,
                         int32_t max_level = texsynth::kMaxDecalStackLevel) {
  texsynth::DecalOptions o;
  o.offset = offset;
  o.stack_step = step;
  o.max_level = max_level;
  return texsynth::build_decal_mesh(sc.s, ps.data(), int64_t(ps.size()), o);
}

// The height of each particle's decal vertices above the plane z = 0 (every vertex of one particle alike).
std::vector<double> particle_heights(const DecalMesh& d, size_t particles) {
  std::vector<double> h(particles, -1);
  for (size_t f = 0; f < d.loop_starts.size(); ++f) {
    const size_t i = size_t(d.face_particle[f]);
    for (int32_t k = 0; k < d.loop_totals[f]; ++k) {
      const double z = vertex(d.positions, d.corner_verts[size_t(d.loop_starts[f] + k)]).z;
      if (h[i] < 0) h[i] = z;
      EXPECT_NEAR(z, h[i], 1e-7) << "particle " << i << " is not flat";
    }
  }
  return h;
}

}  // namespace

// Overlapping decals of one call would z-fight at one height: decals whose rectangles overlap get different
// levels (the lowest free one, in particle order) and lie a step higher per level; separate decals stay down.
TEST(ParticlesDecal, OverlappingDecalsGetDifferentLevels) {
  const Scene sc(quad(5.0));
  auto at = [&](double x, double y, double angle = 0) {
    return particle(locate(sc.mesh, {x, y, 0}), {std::cos(angle), std::sin(angle), 0}, {-0.5, -0.5, 0.5, 0.5});
  };
  // 0 overlaps 1, 1 overlaps 2 (0 and 2 are apart), 3 overlaps 0 and 1, 4 is alone.
  const std::vector<DecalParticle> ps{at(0, 0), at(0.8, 0), at(1.6, 0.1), at(0.4, 0.6), at(-3, -3)};
  const double offset = 0.01, step = 0.002;
  const DecalMesh d = stacked_decals(sc, ps, offset, step);
  EXPECT_EQ(d.level, (std::vector<int32_t>{0, 1, 0, 2, 0}));
  const std::vector<double> h = particle_heights(d, ps.size());
  for (size_t i = 0; i < ps.size(); ++i) EXPECT_NEAR(h[i], offset + d.level[i] * step, 1e-7) << "particle " << i;
  EXPECT_EQ(d.stats.stacked, 2);
  EXPECT_EQ(d.stats.max_level, 2);
  // Without a step every decal keeps the one offset and level 0, as before stacking existed.
  const DecalMesh flat = stacked_decals(sc, ps, offset, 0);
  EXPECT_EQ(flat.level, std::vector<int32_t>(ps.size(), 0));
  for (double z : particle_heights(flat, ps.size())) EXPECT_NEAR(z, offset, 1e-7);
  // Rectangles, not their circles: unit squares (1.05, 0.3) apart overlap as circles (1.09 < 1.41) but not as
  // squares (x gap 1.05 > 1); turned 45 degrees the same squares overlap (0.95 < 1 along their edge normals).
  EXPECT_EQ(stacked_decals(sc, {at(0, 0), at(1.05, 0.3)}, offset, step).stats.stacked, 0);
  EXPECT_EQ(stacked_decals(sc, {at(0, 0, kPi / 4), at(1.05, 0.3, kPi / 4)}, offset, step).stats.stacked, 1);
  // Edge to edge (1.0 apart): touching is not overlapping.
  EXPECT_EQ(stacked_decals(sc, {at(0, 0), at(1.0, 0)}, offset, step).stats.stacked, 0);
}

TEST(ParticlesDecal, ManyDecalsOnOneSpotShareTheCap) {
  const Scene sc(quad(5.0));
  const DecalParticle p = particle(locate(sc.mesh, {0.1, 0.2, 0}), {1, 0, 0}, {-0.2, -0.2, 0.2, 0.2});
  const std::vector<DecalParticle> ps(size_t(texsynth::kMaxDecalStackLevel) + 10, p);
  const DecalMesh d = stacked_decals(sc, ps, 0, 1e-5);
  EXPECT_EQ(d.stats.max_level, texsynth::kMaxDecalStackLevel);
  for (size_t i = 0; i < ps.size(); ++i)
    EXPECT_EQ(d.level[i], std::min<int32_t>(int32_t(i), texsynth::kMaxDecalStackLevel));
  const std::vector<double> h = particle_heights(d, ps.size());
  EXPECT_NEAR(h.back(), texsynth::kMaxDecalStackLevel * 1e-5, 1e-7);
  // A smaller cap keeps the band lower: the last two of three stacked decals share the top level.
  const DecalMesh capped = stacked_decals(sc, {p, p, p}, 0, 1e-3, 1);
  EXPECT_EQ(capped.level, (std::vector<int32_t>{0, 1, 1}));
  for (double step : {-1e-3, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()})
    expect_refused([&] { stacked_decals(sc, {p}, 0, step); }, "stack_step");
  for (int32_t cap : {-1, texsynth::kMaxDecalStackLevel + 1})
    expect_refused([&] { stacked_decals(sc, {p}, 0, 1e-3, cap); }, "max_level");
}

// One footprint as wide as the mesh makes the grid one cell: the pair tests stop at their bound, the rest keep
// level 0 and are counted, and the call stays fast. Tiny footprints (cells far smaller than the coordinates)
// are clamped, not overflowed.
TEST(ParticlesDecal, StackingWorkIsBoundedAndTinyFootprintsAreSafe) {
  const Scene sc(quad(5.0));
  std::vector<DecalParticle> ps{particle(locate(sc.mesh, {0, 0, 0}), {1, 0, 0}, {-4.9, -4.9, 4.9, 4.9})};
  texsynth::Rng rng(5);
  for (int i = 0; i < 3000; ++i)
    ps.push_back(particle(locate(sc.mesh, {rng.uniform() * 9 - 4.5, rng.uniform() * 9 - 4.5, 0}), {1, 0, 0},
                          {-0.05, -0.05, 0.05, 0.05}));
  const DecalMesh d = stacked_decals(sc, ps, 0, 1e-4);
  EXPECT_GT(d.stats.unstacked, 0);
  EXPECT_LT(d.stats.unstacked, int64_t(ps.size()));
  for (size_t i = ps.size() - size_t(d.stats.unstacked); i < ps.size(); ++i) EXPECT_EQ(d.level[i], 0);
  EXPECT_EQ(d.level[1], 1);  // the first small one lies on the big one
  const std::vector<DecalParticle> tiny{particle(locate(sc.mesh, {3, 3, 0}), {1, 0, 0}, {-1e-200, -1e-200, 1e-200, 1e-200}),
                                        particle(locate(sc.mesh, {3, 3, 0}), {1, 0, 0}, {-1e-200, -1e-200, 1e-200, 1e-200})};
  // Their corners round onto the centre (3 + 1e-200 == 3), so whether they overlap is rounding's call; the
  // call must only stay defined (cells clamped) and give valid levels.
  const DecalMesh t = stacked_decals(sc, tiny, 0, 1e-4);
  EXPECT_EQ(t.level[0], 0);
  EXPECT_LE(t.level[1], 1);
  EXPECT_EQ(t.stats.unstacked, 0);
}
