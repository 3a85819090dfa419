// SPDX-License-Identifier: GPL-3.0-or-later
// Particle placement on the surface (particles/placement.hpp) on samples drawn from labels whose
// arrangement is known (a grid of equal squares, jittered discs): the plane reproduces the grid in
// world units, fields turn it, scale and overrides change counts by the laws of the plan, a torus is
// covered, components are seeded, classes are independent, threads do not matter, bad input is refused.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "cancel_latency.hpp"
#include "placement_fixtures.hpp"
#include "texsynth/common/errors.hpp"
#include "texsynth/common/rng.hpp"
#include "texsynth/particles/placement.hpp"

namespace {

using ring_fixtures::TriMesh;
using texsynth::PlacedParticles;
using texsynth::PlacementParams;
using texsynth::V3;
using namespace placement_fixtures;

// n x n squares of `side` px, `gap` px apart, 14 px from the edges: centre spacing side + gap.
LabelSample square_grid(int n = 6, int side = 20, int gap = 8) {
  const int W = 28 + n * side + (n - 1) * gap;
  LabelSample s = blank(W, W);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) s.fill(14 + i * (side + gap), 14 + j * (side + gap), side, side, 1);
  return s;
}

struct Scene {
  TriMesh mesh;
  texsynth::SurfaceWalkMesh walk;
  explicit Scene(TriMesh m) : mesh(std::move(m)), walk(texsynth::build_surface_walk_mesh(mesh.input())) {}
  int32_t V() const { return mesh.num_vertices(); }
  int32_t T() const { return mesh.num_triangles(); }
  // "up" = (cos a, sin a, 0) turned by `degrees` from +y, at every vertex.
  std::vector<float> field(double degrees) const {
    const double a = (90 + degrees) * kPi / 180;
    std::vector<float> d;
    for (int32_t v = 0; v < V(); ++v) d.insert(d.end(), {float(std::cos(a)), float(std::sin(a)), 0.f});
    return d;
  }
  V3 vertex(int32_t v) const {
    return {mesh.positions[3 * size_t(v)], mesh.positions[3 * size_t(v) + 1], mesh.positions[3 * size_t(v) + 2]};
  }
  V3 centroid(int32_t t) const {
    const int32_t* c = &mesh.triangles[3 * size_t(t)];
    return (vertex(c[0]) + vertex(c[1]) + vertex(c[2])) * (1.0 / 3);
  }
};

// A 6 x 6 plane of 60 x 60 cells (corners at multiples of 0.1, so x = 3 is a line of edges).
Scene flat_plane(double jitter = 0.0) { return Scene(ring_fixtures::plane(60, 60, 0.1, jitter, 3)); }

PlacementParams params_for(const Scene& s, const texsynth::ParticleAnalysis& a, double pixel, double degrees = 0) {
  PlacementParams p;
  p.directions = s.field(degrees);
  p.sample_world_width = pixel * a.width;
  return p;
}

V3 position(const PlacedParticles& r, size_t i) {
  return {r.position[3 * i], r.position[3 * i + 1], r.position[3 * i + 2]};
}
V3 axis(const PlacedParticles& r, size_t i) {
  return {r.sprite_axis[3 * i], r.sprite_axis[3 * i + 1], r.sprite_axis[3 * i + 2]};
}

int64_t count_in(const PlacedParticles& r, double x0, double x1, double y0, double y1) {
  int64_t n = 0;
  for (size_t i = 0; i < r.size(); ++i) {
    const V3 p = position(r, i);
    n += p.x >= x0 && p.x < x1 && p.y >= y0 && p.y < y1;
  }
  return n;
}

// Placed centres sit on the lattice of step `step` along (right, up) through the first particle, each
// lattice point inside [0, 6]^2 exactly once.
void expect_lattice(const PlacedParticles& r, double step, double degrees) {
  ASSERT_GT(r.size(), 100u);
  const double a = degrees * kPi / 180;
  const V3 right{std::cos(a), std::sin(a), 0}, up{-std::sin(a), std::cos(a), 0}, p0 = position(r, 0);
  double worst = 0;
  std::vector<std::pair<long, long>> cells;
  for (size_t i = 0; i < r.size(); ++i) {
    const V3 d = position(r, i) - p0;
    const double u = texsynth::dot(d, right) / step, v = texsynth::dot(d, up) / step;
    worst = std::max({worst, std::abs(u - std::round(u)) * step, std::abs(v - std::round(v)) * step});
    cells.push_back({std::lround(u), std::lround(v)});
    EXPECT_LT(texsynth::norm(axis(r, i) - right), 1e-5) << "sprite axis of " << i;
    EXPECT_LE(r.origin[i], 1) << "no reseeding on a covered plane";
  }
  EXPECT_LT(worst, 1e-4) << "centre off the lattice (world units)";
  std::sort(cells.begin(), cells.end());
  EXPECT_EQ(std::unique(cells.begin(), cells.end()), cells.end()) << "two particles on one lattice point";
  // Every lattice point inside the plane is taken. A point hugging the border (within 0.05, a sixth of
  // the step) may be reached or not: the clang sanitizer build lost 2 of 461 at 30 deg, 4e-3 and 6e-3
  // from the border, which the g++ build reaches.
  int64_t strictly_inside = 0, inside = 0;
  for (long i = -40; i <= 40; ++i)
    for (long j = -40; j <= 40; ++j) {
      const V3 x = p0 + right * (i * step) + up * (j * step);
      inside += x.x > 1e-6 && x.x < 6 - 1e-6 && x.y > 1e-6 && x.y < 6 - 1e-6;
      strictly_inside += x.x > 0.05 && x.x < 6 - 0.05 && x.y > 0.05 && x.y < 6 - 0.05;
    }
  int64_t placed_strictly_inside = 0;
  for (size_t i = 0; i < r.size(); ++i) {
    const V3 x = position(r, i);
    placed_strictly_inside += x.x > 0.05 && x.x < 6 - 0.05 && x.y > 0.05 && x.y < 6 - 0.05;
  }
  EXPECT_EQ(placed_strictly_inside, strictly_inside);
  EXPECT_LE(int64_t(r.size()), inside);
  std::printf("lattice %.0f deg: %zu particles, worst offset %.2g world units\n", degrees, r.size(), worst);
}

TEST(ParticlesPlace, PlaneReproducesTheSquareGridInWorldUnits) {
  const texsynth::ParticleAnalysis a = analyse(square_grid());
  const Scene s = flat_plane(0.3);
  const PlacedParticles r = texsynth::place_particles(a, s.walk, params_for(s, a, 0.01));
  // 20 px squares 8 px apart at 0.01 world units per pixel: a 0.28 lattice, boxes 0.2 wide.
  expect_lattice(r, 0.28, 0);
  for (size_t i = 0; i < r.size(); ++i) {
    EXPECT_FLOAT_EQ(r.pixel_size[i], 0.01f);
    EXPECT_EQ(r.angle[i], 0.f);
    EXPECT_EQ(r.class_id[i], 1);
  }
  EXPECT_EQ(r.origin[0], 0);
  EXPECT_EQ(r.parent[0], -1);
  // The seed is the area centroid of the (jittered) plane, which lies on it.
  V3 centroid;
  double area = 0;
  for (int32_t t = 0; t < s.T(); ++t) {
    const int32_t* c = &s.mesh.triangles[3 * size_t(t)];
    const double w = texsynth::norm(texsynth::cross(s.vertex(c[1]) - s.vertex(c[0]), s.vertex(c[2]) - s.vertex(c[0])));
    centroid = centroid + s.centroid(t) * w, area += w;
  }
  EXPECT_LT(texsynth::norm(position(r, 0) - centroid * (1 / area)), 1e-6);
}

TEST(ParticlesPlace, ThirtyDegreeFieldTurnsTheGrid) {
  const texsynth::ParticleAnalysis a = analyse(square_grid());
  const Scene s = flat_plane(0.3);
  expect_lattice(texsynth::place_particles(a, s.walk, params_for(s, a, 0.01, 30)), 0.28, 30);
}

TEST(ParticlesPlace, ParticlesFollowARotatingField) {
  const texsynth::ParticleAnalysis a = analyse(square_grid());
  const Scene s = flat_plane(0.3);
  PlacementParams p = params_for(s, a, 0.01);
  // The field turns by 0.25 rad per world unit along x: 2 degrees from one square to the next.
  auto field_angle = [](V3 x) { return 0.25 * (x.x - 3); };
  for (int32_t v = 0; v < s.V(); ++v) {
    const double t = field_angle(s.vertex(v));
    p.directions[3 * size_t(v)] = float(-std::sin(t)), p.directions[3 * size_t(v) + 1] = float(std::cos(t));
  }
  const PlacedParticles r = texsynth::place_particles(a, s.walk, p);
  ASSERT_GT(r.size(), 200u);
  std::vector<double> axis_err, neighbour_err;
  for (size_t i = 0; i < r.size(); ++i) {
    const V3 x = position(r, i), ax = axis(r, i);
    // The sprite is drawn along the field's "right" where it stands (linear field, so within interpolation).
    axis_err.push_back(std::abs(std::remainder(std::atan2(ax.y, ax.x) - field_angle(x), 2 * kPi)));
    // Its nearest neighbour lies along the field's axes at their midpoint (a square grid bent by the
    // field; a child is placed in its parent's frame, half a step's turn = 2 degrees from the midpoint's).
    double best = 1e9, dir = 0;
    V3 mid;
    for (size_t j = 0; j < r.size(); ++j) {
      const V3 d = position(r, j) - x;
      const double l = texsynth::norm(d);
      if (j != i && l < best) best = l, dir = std::atan2(d.y, d.x), mid = x + d * 0.5;
    }
    neighbour_err.push_back(std::abs(std::remainder(dir - field_angle(mid), kPi / 2)));
  }
  std::sort(axis_err.begin(), axis_err.end());
  std::sort(neighbour_err.begin(), neighbour_err.end());
  const double axis_worst = axis_err.back() * 180 / kPi,
               nb_median = neighbour_err[neighbour_err.size() / 2] * 180 / kPi;
  // Each child lies from its parent along the sample's axes or diagonals in the field at the parent.
  double child_worst = 0;
  for (size_t i = 0; i < r.size(); ++i) {
    if (r.parent[i] < 0) continue;
    const V3 from = position(r, size_t(r.parent[i])), d = position(r, i) - from;
    child_worst = std::max(child_worst, std::abs(std::remainder(std::atan2(d.y, d.x) - field_angle(from), kPi / 4)));
  }
  std::printf(
      "rotating field: %zu particles, axis error worst %.3f deg, child direction worst %.3f deg, "
      "nearest-neighbour direction median %.2f deg (midpoint field; lattice defects from the field's turn)\n",
      r.size(), axis_worst, child_worst * 180 / kPi, nb_median);
  EXPECT_LT(axis_worst, 0.5);
  EXPECT_LT(child_worst * 180 / kPi, 0.2);
  EXPECT_LT(nb_median, 6.0);
  // The grid turns with the field: particles at the right end are turned ~0.75 rad from the left end's.
  double left = 0, right = 0;
  int nl = 0, nr = 0;
  for (size_t i = 0; i < r.size(); ++i) {
    const double ang = std::atan2(axis(r, i).y, axis(r, i).x);
    if (position(r, i).x < 1) left += ang, ++nl;
    if (position(r, i).x > 5) right += ang, ++nr;
  }
  ASSERT_GT(nl, 10);
  ASSERT_GT(nr, 10);
  EXPECT_NEAR(right / nr - left / nl, 0.25 * 4.5, 0.15);
}

TEST(ParticlesPlace, ScaleChangesTheCountPerAreaByItsSquare) {
  const texsynth::ParticleAnalysis a = analyse(jittered_discs());
  const Scene s = flat_plane(0.3);
  const PlacedParticles base = texsynth::place_particles(a, s.walk, params_for(s, a, 0.005));
  const PlacedParticles wide = texsynth::place_particles(a, s.walk, params_for(s, a, 0.01));  // Scale x 2
  PlacementParams fine = params_for(s, a, 0.01);
  fine.vertex_scale.assign(size_t(s.V()), 2.f);  // multiplier 2: features half as large again
  const PlacedParticles finer = texsynth::place_particles(a, s.walk, fine);
  const double n_base = double(count_in(base, 1, 5, 1, 5)), n_wide = double(count_in(wide, 1, 5, 1, 5)),
               n_fine = double(count_in(finer, 1, 5, 1, 5));
  std::printf("scale: %g particles in the window, Scale x2 -> %g (ratio %.3f), multiplier 2 on that -> %g (%.3f)\n",
              n_base, n_wide, n_wide / n_base, n_fine, n_fine / n_wide);
  ASSERT_GT(n_base, 300);
  EXPECT_NEAR(n_wide / n_base, 0.25, 0.025);
  EXPECT_NEAR(n_fine / n_wide, 4.0, 0.4);
  for (size_t i = 0; i < finer.size(); ++i) ASSERT_FLOAT_EQ(finer.pixel_size[i], 0.005f);
}

// Nearest-neighbour distances among 2D points; only for points inside [x0, x1] x [y0, y1] (all points
// count as neighbours).
std::vector<double> nearest_distances(const std::vector<std::pair<double, double>>& pts, double x0, double x1,
                                      double y0, double y1) {
  std::vector<double> out;
  for (size_t i = 0; i < pts.size(); ++i) {
    const auto [x, y] = pts[i];
    if (x < x0 || x > x1 || y < y0 || y > y1) continue;
    double best = 1e300;
    for (size_t j = 0; j < pts.size(); ++j)
      if (j != i) best = std::min(best, std::hypot(pts[j].first - x, pts[j].second - y));
    out.push_back(best);
  }
  std::sort(out.begin(), out.end());
  return out;
}

// Two-sample Kolmogorov-Smirnov statistic of sorted samples.
double ks_statistic(const std::vector<double>& a, const std::vector<double>& b) {
  double d = 0;
  size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    const double v = std::min(a[i], b[j]);
    while (i < a.size() && a[i] <= v) ++i;
    while (j < b.size() && b[j] <= v) ++j;
    d = std::max(d, std::abs(double(i) / a.size() - double(j) / b.size()));
  }
  return d;
}

TEST(ParticlesPlace, PlaneArrangementMatchesTheSampleWithinItsOwnNoise) {
  // A larger irregular sample (1024^2 px, ~1000 discs) placed on the plane; distances in sample pixels.
  const texsynth::ParticleAnalysis a = analyse(jittered_discs(1024, 21));
  std::vector<std::pair<double, double>> sample;
  for (const auto& P : a.particles) sample.push_back({P.box.cx, P.box.cy});
  const double W = a.width, m = 64;  // interior margin, px
  const auto whole = nearest_distances(sample, m, W - m, m, W - m);
  const auto left = nearest_distances(sample, m, W / 2, m, W - m),
             right = nearest_distances(sample, W / 2, W - m, m, W - m);
  const Scene s = flat_plane(0.3);
  const double pixel = 0.004;  // 32 px spacing = 0.128 world units: ~2000 particles on the plane
  const PlacedParticles r = texsynth::place_particles(a, s.walk, params_for(s, a, pixel));
  std::vector<std::pair<double, double>> placed;
  for (size_t i = 0; i < r.size(); ++i) placed.push_back({position(r, i).x / pixel, position(r, i).y / pixel});
  const double M = 6 / pixel;
  const auto got = nearest_distances(placed, m, M - m, m, M - m);
  const double ks = ks_statistic(got, whole), ks_halves = ks_statistic(left, right);
  const double density = double(got.size()) / ((M - 2 * m) * (M - 2 * m)),
               sample_density = double(whole.size()) / ((W - 2 * m) * (W - 2 * m));
  std::printf(
      "arrangement: nearest distance median %.1f px placed vs %.1f sample; KS %.3f (sample halves %.3f); "
      "density ratio %.3f\n",
      got[got.size() / 2], whole[whole.size() / 2], ks, ks_halves, density / sample_density);
  // Measured 0.18 against 0.11 between the sample's halves, 1.32 x the density (box overlap alone: KS
  // 0.81, 2.49 x): the propagation keeps neighbours' gaps but not a jittered lattice's long-range order.
  EXPECT_LE(ks, std::max(2 * ks_halves, 0.1));
  EXPECT_NEAR(got[got.size() / 2] / whole[whole.size() / 2], 1.0, 0.05);
  EXPECT_LT(density / sample_density, 1.4);
  EXPECT_GT(density / sample_density, 0.9);
}

// Per-triangle override: `left` for faces with centroids at x < 3, else `right`.
std::vector<float> halves(const Scene& s, float left, float right) {
  std::vector<float> v(size_t(s.T()));
  for (int32_t t = 0; t < s.T(); ++t) v[size_t(t)] = s.centroid(t).x < 3 ? left : right;
  return v;
}

TEST(ParticlesPlace, DensityOverrideThinsAndZeroEmpties) {
  const texsynth::ParticleAnalysis a = analyse(jittered_discs());
  const Scene s = flat_plane(0.0);
  PlacementParams p = params_for(s, a, 0.005);
  p.face_density = halves(s, 0.5f, 1.f);
  const PlacedParticles half = texsynth::place_particles(a, s.walk, p);
  const double left = double(count_in(half, 0.5, 2.5, 0.5, 5.5)), right = double(count_in(half, 3.5, 5.5, 0.5, 5.5));
  p.face_density = halves(s, 0.f, 1.f);
  const PlacedParticles none = texsynth::place_particles(a, s.walk, p);
  std::printf("density 0.5 | 1: %g | %g particles (ratio %.3f); density 0 | 1: %lld left\n", left, right, left / right,
              static_cast<long long>(count_in(none, 0, 3, 0, 6)));
  EXPECT_NEAR(left / right, 0.5, 0.06);
  EXPECT_EQ(count_in(none, 0, 3, 0, 6), 0);
  EXPECT_NEAR(double(count_in(none, 3.5, 5.5, 0.5, 5.5)) / right, 1.0, 0.1);
  // Seeds land where the density allows (the centre seed is on the line: re-seeding covers the right).
  EXPECT_GT(none.size(), 0.8 * right * 2.5 / 2);
}

TEST(ParticlesPlace, ProbabilityHidesParticlesWithoutMovingAny) {
  const texsynth::ParticleAnalysis a = analyse(jittered_discs());
  const Scene s = flat_plane(0.0);
  PlacementParams p = params_for(s, a, 0.005);
  const PlacedParticles all = texsynth::place_particles(a, s.walk, p);
  p.face_probability = halves(s, 0.5f, 1.f);
  const PlacedParticles some = texsynth::place_particles(a, s.walk, p);
  // Every output particle of the thinned run is a particle of the full run (same placement, same bytes).
  size_t j = 0, same = 0;
  for (size_t i = 0; i < some.size(); ++i) {
    while (j < all.size() && std::memcmp(&all.position[3 * j], &some.position[3 * i], 12) != 0) ++j;
    same += j < all.size();
  }
  EXPECT_EQ(same, some.size());
  const double kept_left = double(count_in(some, 0, 3, 0, 6)) / double(count_in(all, 0, 3, 0, 6));
  std::printf("probability 0.5: %.3f of the left half kept, right %lld of %lld\n", kept_left,
              static_cast<long long>(count_in(some, 3, 6, 0, 6)), static_cast<long long>(count_in(all, 3, 6, 0, 6)));
  EXPECT_NEAR(kept_left, 0.5, 0.06);
  EXPECT_EQ(count_in(some, 3.05, 6, 0, 6), count_in(all, 3.05, 6, 0, 6));
  int64_t hidden = 0;
  for (const auto& c : some.stats.classes) hidden += c.hidden;
  EXPECT_EQ(int64_t(all.size()), int64_t(some.size()) + hidden);
  // Parents point at output rows (the nearest shown ancestor).
  for (size_t i = 0; i < some.size(); ++i) EXPECT_LT(some.parent[i], int32_t(i));
}

TEST(ParticlesPlace, SizeOverrideScalesBoxesNotGapsAndJitterSpreadsSizes) {
  const texsynth::ParticleAnalysis a = analyse(square_grid());
  const Scene s = flat_plane(0.0);
  PlacementParams p = params_for(s, a, 0.01);
  // Size 2: 40 px squares still 8 px apart, a 0.48 lattice.
  p.face_size.assign(size_t(s.T()), 2.f);
  const PlacedParticles doubled = texsynth::place_particles(a, s.walk, p);
  expect_lattice(doubled, 0.48, 0);
  for (size_t i = 0; i < doubled.size(); ++i) ASSERT_FLOAT_EQ(doubled.pixel_size[i], 0.02f);
  // Halves: each particle takes the size of where it stands.
  p.face_size = halves(s, 2.f, 1.f);
  const PlacedParticles r = texsynth::place_particles(a, s.walk, p);
  int64_t left = 0, right = 0;
  for (size_t i = 0; i < r.size(); ++i) {
    const double x = position(r, i).x;
    if (x < 2.9) {
      EXPECT_FLOAT_EQ(r.pixel_size[i], 0.02f);
      ++left;
    }
    if (x > 3.1) {
      EXPECT_FLOAT_EQ(r.pixel_size[i], 0.01f);
      ++right;
    }
  }
  // Counts per area follow the spacings: (0.48 / 0.28)^2 = 2.94 times more on the right.
  EXPECT_GT(left, 20);
  EXPECT_NEAR(double(right) / double(left), 2.94, 0.4);

  PlacementParams j = params_for(s, a, 0.01);
  j.size_jitter = 0.3;
  const PlacedParticles jr = texsynth::place_particles(a, s.walk, j);
  const auto [lo, hi] = std::minmax_element(jr.pixel_size.begin(), jr.pixel_size.end());
  EXPECT_GE(*lo, 0.01f * 0.7f * 0.9999f);
  EXPECT_LE(*hi, 0.01f * 1.3f * 1.0001f);
  EXPECT_LT(*lo, 0.0075f);
  EXPECT_GT(*hi, 0.0125f);
}

// Two classes from labels: squares (class 1) and discs (class 2) in one sample.
LabelSample two_classes() {
  LabelSample s = jittered_discs(256, 4, 2);
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 4; ++i) s.fill(8 + 64 * i, 8 + 64 * j, 14, 14, 1);
  return s;
}

TEST(ParticlesPlace, OneClassAloneGivesExactlyItsRowsOfTheFullRun) {
  // Re-synthesizing one class (output_classes = {k}): the classes before it are placed again (they
  // constrain it: conflicts run against every class), only its rows come out.
  const texsynth::ParticleAnalysis a = analyse(two_classes());
  ASSERT_EQ(a.num_classes, 3);
  const Scene s = flat_plane(0.3);
  PlacementParams p = params_for(s, a, 0.006);
  p.size_jitter = 0.2;
  p.face_probability = halves(s, 0.7f, 1.f);
  const PlacedParticles full = texsynth::place_particles(a, s.walk, p);
  ASSERT_EQ(full.stats.classes.size(), 2u);
  for (int32_t k : {1, 2}) {
    p.output_classes = {k};
    const PlacedParticles one = texsynth::place_particles(a, s.walk, p);
    ASSERT_EQ(one.stats.classes.size(), 1u);
    EXPECT_EQ(one.stats.classes[0].class_id, k);
    size_t first = 0;
    while (first < full.size() && full.class_id[first] != k) ++first;
    ASSERT_GT(one.size(), 20u);
    ASSERT_LE(first + one.size(), full.size());
    for (size_t i = 0; i < one.size(); ++i) {
      SCOPED_TRACE("class " + std::to_string(k) + " row " + std::to_string(i));
      ASSERT_EQ(full.class_id[first + i], k);
      ASSERT_EQ(std::memcmp(&full.position[3 * (first + i)], &one.position[3 * i], 12), 0);
      ASSERT_EQ(std::memcmp(&full.sprite_axis[3 * (first + i)], &one.sprite_axis[3 * i], 12), 0);
      ASSERT_EQ(full.sprite[first + i], one.sprite[i]);
      ASSERT_EQ(full.pixel_size[first + i], one.pixel_size[i]);
      ASSERT_EQ(full.parent[first + i], one.parent[i] < 0 ? -1 : one.parent[i] + int32_t(first));
    }
    EXPECT_TRUE(first + one.size() == full.size() || full.class_id[first + one.size()] != k);
  }
}

// Fraction of the area farther than `reach` from every particle centre: area-weighted random points.
double uncovered_fraction(const Scene& s, const PlacedParticles& r, double reach, int samples = 20000) {
  std::vector<double> cdf;
  double acc = 0;
  for (int32_t t = 0; t < s.T(); ++t) {
    const int32_t* c = &s.mesh.triangles[3 * size_t(t)];
    acc += texsynth::norm(texsynth::cross(s.vertex(c[1]) - s.vertex(c[0]), s.vertex(c[2]) - s.vertex(c[0])));
    cdf.push_back(acc);
  }
  texsynth::Rng rng(77);
  int uncovered = 0;
  for (int k = 0; k < samples; ++k) {
    const int32_t t = int32_t(std::upper_bound(cdf.begin(), cdf.end(), rng.uniform() * acc) - cdf.begin());
    double b1 = rng.uniform(), b2 = rng.uniform();
    if (b1 + b2 > 1) b1 = 1 - b1, b2 = 1 - b2;
    const int32_t* c = &s.mesh.triangles[3 * size_t(std::min(t, s.T() - 1))];
    const V3 x = s.vertex(c[0]) * (1 - b1 - b2) + s.vertex(c[1]) * b1 + s.vertex(c[2]) * b2;
    bool near = false;
    for (size_t i = 0; i < r.size() && !near; ++i) near = texsynth::norm(position(r, i) - x) <= reach;
    uncovered += !near;
  }
  return double(uncovered) / samples;
}

TEST(ParticlesPlace, TorusIsCovered) {
  const texsynth::ParticleAnalysis a = analyse(jittered_discs());
  const Scene s(torus(160, 64, 1.0, 0.4));
  PlacementParams p;
  p.directions = ring_field(s.mesh);
  const double pixel = 0.003;
  p.sample_world_width = pixel * a.width;
  const PlacedParticles r = texsynth::place_particles(a, s.walk, p);
  // Uncovered: farther than one mean spacing of the sample's discs from every centre.
  const double u = uncovered_fraction(s, r, kDiscSpacing * pixel);
  int64_t reseeded = 0;
  for (size_t i = 0; i < r.size(); ++i) reseeded += r.origin[i] == 2;
  std::printf("torus: %zu particles (%lld reseeded, %d rounds), uncovered %.2f %% of the area\n", r.size(),
              static_cast<long long>(reseeded), r.stats.classes[0].reseed_rounds, 100 * u);
  EXPECT_LE(u, 0.05);
  EXPECT_EQ(r.stats.components, 1);
}

TEST(ParticlesPlace, EveryComponentGetsParticlesAndGivenSeedsAreUsed) {
  // Two planes 10 apart, one mesh.
  TriMesh m = ring_fixtures::plane(30, 30, 0.1, 0.2, 5);
  const int32_t nv = m.num_vertices(), nt = m.num_triangles();
  for (int32_t v = 0; v < nv; ++v) m.add_vertex(m.positions[3 * size_t(v)] + 10, m.positions[3 * size_t(v) + 1], 0);
  for (int32_t t = 0; t < nt; ++t)
    m.add_triangle(m.triangles[3 * size_t(t)] + nv, m.triangles[3 * size_t(t) + 1] + nv,
                   m.triangles[3 * size_t(t) + 2] + nv);
  const Scene s(std::move(m));
  const texsynth::ParticleAnalysis a = analyse(jittered_discs());
  PlacementParams p = params_for(s, a, 0.004);
  const PlacedParticles r = texsynth::place_particles(a, s.walk, p);
  EXPECT_EQ(r.stats.components, 2);
  const int64_t first = count_in(r, 0, 3, 0, 3), second = count_in(r, 10, 13, 0, 3);
  std::printf("two components: %lld and %lld particles\n", static_cast<long long>(first),
              static_cast<long long>(second));
  EXPECT_GT(first, 50);
  EXPECT_NEAR(double(second) / double(first), 1.0, 0.15);
  // A given seed on the second plane: its first particle is there, the first plane still seeded.
  p.seeds = {{nt + 100, 0.25, 0.25}};
  const PlacedParticles g = texsynth::place_particles(a, s.walk, p);
  const int32_t* c = &s.mesh.triangles[3 * size_t(nt + 100)];
  const V3 want = s.vertex(c[0]) * 0.5 + s.vertex(c[1]) * 0.25 + s.vertex(c[2]) * 0.25;
  bool seeded_there = false;
  for (size_t i = 0; i < g.size(); ++i)
    seeded_there |= g.origin[i] == 0 && texsynth::norm(position(g, i) - want) < 1e-5;
  EXPECT_TRUE(seeded_there);
  EXPECT_GT(count_in(g, 0, 3, 0, 3), 50);
}

TEST(ParticlesPlace, ReseedingCoversWhatPropagationCannotReach) {
  // A band of density 0 (x in [2.5, 3.5], wider than any child offset) splits the plane; the only
  // seed is on the left, so the right half is reached by re-seeding alone.
  const texsynth::ParticleAnalysis a = analyse(jittered_discs());
  const Scene s = flat_plane(0.0);
  PlacementParams p = params_for(s, a, 0.005);
  p.face_density.assign(size_t(s.T()), 1.f);
  for (int32_t t = 0; t < s.T(); ++t)
    if (std::abs(s.centroid(t).x - 3) < 0.5) p.face_density[size_t(t)] = 0;
  p.seeds = {{0, 0.3, 0.3}};  // the lower left corner
  const PlacedParticles r = texsynth::place_particles(a, s.walk, p);
  int64_t right = 0, reseeded_right = 0;
  for (size_t i = 0; i < r.size(); ++i) {
    const double x = position(r, i).x;
    EXPECT_FALSE(x > 2.5 && x < 3.5) << "a particle in the empty band";
    right += x > 3.5;
    reseeded_right += x > 3.5 && r.origin[i] == 2;
  }
  // Compared with the left half, which propagation reached from the seed.
  const int64_t left = count_in(r, 0, 2.5, 0, 6);
  std::printf("reseeding: %lld left, %lld right (%lld reseeded there), %d rounds\n", static_cast<long long>(left),
              static_cast<long long>(right), static_cast<long long>(reseeded_right), r.stats.classes[0].reseed_rounds);
  EXPECT_GE(reseeded_right, 1);
  EXPECT_NEAR(double(right) / double(left), 1.0, 0.1);
}

// The turn between each particle with a parent and its parent (the parent's axis carried into the
// child's tangent plane), worst over particles with z above `z_min`, modulo a half turn (boxes).
double worst_turn_from_parent(const PlacedParticles& r, double z_min, int& counted) {
  double worst = 0;
  counted = 0;
  for (size_t i = 0; i < r.size(); ++i) {
    if (r.parent[i] < 0 || position(r, i).z < z_min) continue;
    ++counted;
    const V3 n{r.normal[3 * i], r.normal[3 * i + 1], r.normal[3 * i + 2]};
    const V3 carried = texsynth::normalized_or(texsynth::project_to_plane(axis(r, size_t(r.parent[i])), n), V3{});
    worst = std::max(worst, std::acos(std::min(1.0, std::abs(texsynth::dot(carried, axis(r, i))))) * 180 / kPi);
  }
  return worst;
}

TEST(ParticlesPlace, WhereTheFieldVanishesParticlesTakeTheParentsDirection) {
  // An unpainted cap (zero vectors within 0.45 rad of the north pole, +z projected elsewhere): inside
  // it every particle takes its parent's direction (texture_particles.md, "Placement": jump <= 15°).
  const Scene s(ring_fixtures::icosphere(5, 1.0));
  const texsynth::ParticleAnalysis a = analyse(jittered_discs());
  PlacementParams p;
  p.directions.assign(size_t(3 * s.V()), 0.f);
  for (int32_t v = 0; v < s.V(); ++v) p.directions[3 * size_t(v) + 2] = s.vertex(v).z > std::cos(0.45) ? 0.f : 1.f;
  p.sample_world_width = 0.002 * a.width;
  int counted = 0;
  const double cap = worst_turn_from_parent(texsynth::place_particles(a, s.walk, p), std::cos(0.35), counted);
  // The same with +z everywhere: the field itself turns a full turn around the pole (a singularity,
  // unavoidable on a sphere), and particles follow it there.
  for (int32_t v = 0; v < s.V(); ++v) p.directions[3 * size_t(v) + 2] = 1.f;
  int counted_pole = 0;
  const double pole = worst_turn_from_parent(texsynth::place_particles(a, s.walk, p), std::cos(0.1), counted_pole);
  std::printf(
      "zero field cap: %d particles, worst turn from the parent %.2f deg; singular +z field within 0.1 rad "
      "of the pole: %d particles, %.1f deg\n",
      counted, cap, counted_pole, pole);
  EXPECT_GT(counted, 50);
  EXPECT_LE(cap, 15.0);
}

TEST(ParticlesPlace, BothSidesOfAThinSheetAreCovered) {
  // A closed flat box 0.001 thick: its two sheets face away from each other, so their particles never
  // conflict although their boxes overlap in projection.
  const Scene s(ring_fixtures::thin_box(40, 0.1, 0.001));
  const texsynth::ParticleAnalysis a = analyse(jittered_discs());
  PlacementParams p = params_for(s, a, 0.004);
  const PlacedParticles r = texsynth::place_particles(a, s.walk, p);
  int64_t top = 0, bottom = 0;
  for (size_t i = 0; i < r.size(); ++i) {
    const V3 x = position(r, i);
    if (x.x < 0.3 || x.x > 3.7 || x.y < 0.3 || x.y > 3.7) continue;  // away from the rim
    top += r.normal[3 * i + 2] > 0.9f;
    bottom += r.normal[3 * i + 2] < -0.9f;
  }
  std::printf("thin sheet: %lld particles on top, %lld below\n", static_cast<long long>(top),
              static_cast<long long>(bottom));
  EXPECT_GT(top, 200);
  EXPECT_NEAR(double(bottom) / double(top), 1.0, 0.15);
}

TEST(ParticlesPlace, RandomClassFollowsTheSampleDensity) {
  // Two discs: a random class (density 2 / 256^2, min distance 0.7 x their distance).
  LabelSample smp = blank(256, 256);
  smp.disc(60, 80, 10, 1);
  smp.disc(190, 170, 12, 1);
  const texsynth::ParticleAnalysis a = analyse(smp);
  ASSERT_TRUE(a.classes[1].random);
  const Scene s = flat_plane(0.3);
  const double pixel = 0.002;  // the sample covers 0.512^2: ~275 expected particles on 36 world units
  const PlacedParticles r = texsynth::place_particles(a, s.walk, params_for(s, a, pixel));
  const double expected = 2.0 / (256.0 * 256.0) * 36 / (pixel * pixel);
  std::printf("random class: %zu placed, %.1f expected\n", r.size(), expected);
  EXPECT_NEAR(double(r.size()) / expected, 1.0, 0.2);
  const double min_d = a.classes[1].min_distance * pixel;
  for (size_t i = 0; i < r.size(); ++i) {
    EXPECT_EQ(r.origin[i], 3);
    for (size_t j = 0; j < i; ++j) EXPECT_GE(texsynth::norm(position(r, i) - position(r, j)), min_d * 0.999);
  }
}

TEST(ParticlesPlace, SameBytesAtOneAndTwoThreads) {
  const texsynth::ParticleAnalysis a = analyse(two_classes());
  const Scene s(torus(120, 48, 1.0, 0.4));
  PlacementParams p;
  p.directions = ring_field(s.mesh);
  p.sample_world_width = 0.004 * a.width;
  p.size_jitter = 0.25;
  p.vertex_scale.resize(size_t(s.V()));
  for (int32_t v = 0; v < s.V(); ++v) p.vertex_scale[size_t(v)] = float(1 + 0.3 * s.vertex(v).x);
  PlacedParticles r[2];
  for (int threads : {1, 2}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
    r[threads - 1] = texsynth::place_particles(a, s.walk, p);
  }
  ASSERT_GT(r[0].size(), 500u);
  ASSERT_EQ(r[0].size(), r[1].size());
  auto same = [](const auto& u, const auto& v) {
    return u.size() == v.size() && std::memcmp(u.data(), v.data(), u.size() * sizeof(u[0])) == 0;
  };
  EXPECT_TRUE(same(r[0].position, r[1].position));
  EXPECT_TRUE(same(r[0].barycentric, r[1].barycentric));
  EXPECT_TRUE(same(r[0].sprite_axis, r[1].sprite_axis));
  EXPECT_TRUE(same(r[0].normal, r[1].normal));
  EXPECT_TRUE(same(r[0].sprite, r[1].sprite));
  EXPECT_TRUE(same(r[0].parent, r[1].parent));
  EXPECT_TRUE(same(r[0].pixel_size, r[1].pixel_size));
  EXPECT_TRUE(same(r[0].angle, r[1].angle));
  EXPECT_TRUE(same(r[0].origin, r[1].origin));
}

TEST(ParticlesPlace, MaxParticlesCapIsReportedNotThrown) {
  const texsynth::ParticleAnalysis a = analyse(jittered_discs());
  const Scene s = flat_plane(0.3);
  PlacementParams p = params_for(s, a, 0.005);
  p.max_particles = 100;
  const PlacedParticles r = texsynth::place_particles(a, s.walk, p);
  EXPECT_EQ(r.size(), 100u);
  EXPECT_TRUE(r.stats.capped);
}

TEST(ParticlesPlace, CancelStopsWithinABoundedAmountOfWork) {
  const texsynth::ParticleAnalysis a = analyse(jittered_discs());
  const Scene s(ring_fixtures::plane(200, 200, 0.05, 0.3, 3));  // 80,000 triangles, 10 x 10
  PlacementParams p = params_for(s, a, 0.0008);
  std::atomic<bool> flag{true};
  p.cancel = &flag;
  EXPECT_THROW(texsynth::place_particles(a, s.walk, p), texsynth::Cancelled);
  const double cpu_ms = texsynth_test::least_cancel_work_cpu_ms([&] {
    flag = false;
    std::atomic<float> progress{0};
    p.progress = &progress;
    std::atomic<double> raised_cpu_ms{0.0};
    std::thread raiser([&] {
      while (progress.load() < 0.05f) std::this_thread::sleep_for(std::chrono::milliseconds(1));
      raised_cpu_ms = texsynth_test::process_cpu_ms();
      flag = true;
    });
    bool cancelled = false;
    try {
      texsynth::place_particles(a, s.walk, p);
    } catch (const texsynth::Cancelled&) {
      cancelled = true;
    }
    const double work = texsynth_test::process_cpu_ms() - raised_cpu_ms;
    raiser.join();
    EXPECT_TRUE(cancelled) << "finished before the flag was seen";
    std::printf("cancel answered after %.1f CPU-ms of work\n", work);
    return work;
  });
  EXPECT_LT(cpu_ms, texsynth_test::kCancelWorkCpuMs);
}

TEST(ParticlesPlace, BadInputIsRefusedNamingIt) {
  const texsynth::ParticleAnalysis a = analyse(two_classes());
  const Scene s = flat_plane(0.0);
  const PlacementParams good = params_for(s, a, 0.01);
  auto refused = [&](PlacementParams p, const std::string& word, const texsynth::ParticleAnalysis* an = nullptr,
                     const texsynth::SurfaceWalkMesh* mesh = nullptr) {
    try {
      texsynth::place_particles(an ? *an : a, mesh ? *mesh : s.walk, p);
      ADD_FAILURE() << "accepted; expected a refusal naming " << word;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(word), std::string::npos) << e.what();
    }
  };
  const float nan = std::nanf("");
  PlacementParams p = good;
  p.directions.pop_back();
  refused(p, "directions");
  p = good, p.directions[4] = nan;
  refused(p, "directions");
  p = good, p.sample_world_width = 0;
  refused(p, "sample_world_width");
  p = good, p.sample_world_width = nan;
  refused(p, "sample_world_width");
  p = good, p.vertex_scale.assign(size_t(s.V()), 1.f), p.vertex_scale[3] = 0;
  refused(p, "vertex_scale");
  p = good, p.vertex_scale.assign(size_t(s.V()) - 1, 1.f);
  refused(p, "vertex_scale");
  p = good, p.face_density.assign(size_t(s.T()), 1.f), p.face_density[0] = -1;
  refused(p, "face_density");
  p = good, p.face_size.assign(size_t(s.T()), 1.f), p.face_size[0] = nan;
  refused(p, "face_size");
  p = good, p.face_probability.assign(size_t(s.T()), 1.f), p.face_probability[5] = 1.5f;
  refused(p, "face_probability");
  p = good, p.face_probability.assign(3, 1.f);
  refused(p, "face_probability");
  p = good, p.size_jitter = 0.95;
  refused(p, "size_jitter");
  p = good, p.max_particles = 0;
  refused(p, "max_particles");
  p = good, p.classes = {7};
  refused(p, "unknown class 7");
  p = good, p.classes = {0};
  refused(p, "background");
  p = good, p.classes = {1, 1};
  refused(p, "twice");
  p = good, p.classes = {1}, p.output_classes = {2};
  refused(p, "output class 2 is not placed (placed classes: 1)");
  p = good, p.output_classes = {5};
  refused(p, "output class 5 is not placed");
  p = good, p.output_classes = {1, 1};
  refused(p, "output class 1 is listed twice");
  p = good, p.seeds = {{s.T(), 0.2, 0.2}};
  refused(p, "seed 0");
  p = good, p.seeds = {{0, 0.9, 0.9}};
  refused(p, "seed 0");
  p = good, p.seeds = {{0, std::nan(""), 0.1}};
  refused(p, "seed 0");
  // A class with particles, none complete (a bar cut by the border), and an analysis without particles.
  LabelSample cut = square_grid(3);
  cut.fill(0, 0, 6, 40, 2);
  const texsynth::ParticleAnalysis ca = analyse(cut);
  ASSERT_FALSE(ca.classes[2].has_complete);
  p = params_for(s, ca, 0.01), p.classes = {2};
  refused(p, "no complete particle", &ca);
  const texsynth::ParticleAnalysis empty = analyse(blank(32, 32));
  refused(params_for(s, empty, 0.01), "analysis", &empty);
  // A mesh without area (all triangles collapsed onto a line).
  TriMesh flat;
  for (int i = 0; i < 4; ++i) flat.add_vertex(i, 0, 0);
  flat.add_triangle(0, 1, 2), flat.add_triangle(1, 2, 3);
  const Scene line(std::move(flat));
  refused(params_for(line, a, 0.01), "no area", nullptr, &line.walk);
}

}  // namespace
