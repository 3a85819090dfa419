// SPDX-License-Identifier: GPL-3.0-or-later
// Texture-particle analysis (particles/analysis.hpp) on synthetic samples whose answers follow from
// their geometry: discs on a flat ground, grids and rows of squares, rectangles cut by the border.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "particle_fixtures.hpp"
#include "texsynth/common/errors.hpp"
#include "texsynth/common/rng.hpp"
#include "texsynth/particles/analysis.hpp"

namespace {

using texsynth::CoOccurrence;
using texsynth::EntrySource;
using texsynth::ParticleAnalysis;
using texsynth::ParticleAnalysisParams;

using particle_fixtures::add_noise;
using particle_fixtures::Colour;
using particle_fixtures::Scene;

constexpr Colour kGround{0.2f, 0.3f, 0.25f};
constexpr Colour kStone{0.8f, 0.7f, 0.3f};

Scene flat(int W, int H, Colour c = kGround) { return particle_fixtures::flat(W, H, c); }

struct Disc {
  double cx, cy, r;
  bool inside(int x, int y) const { return std::hypot(x + 0.5 - cx, y + 0.5 - cy) <= r; }
};

void paint_disc(Scene& s, const Disc& d, Colour c) {
  for (int y = 0; y < s.H; ++y)
    for (int x = 0; x < s.W; ++x)
      if (d.inside(x, y)) s.set(x, y, c);
}

void paint_rect(Scene& s, int x0, int y0, int w, int h, Colour c) {
  for (int y = y0; y < y0 + h; ++y)
    for (int x = x0; x < x0 + w; ++x) s.set(x, y, c);
}

// Discs of radii 10..16 on a 40 px lattice (>= 8 px apart, >= 14 px from the edges) plus one disc of
// radius 10 cut by the left border (centre 3 px inside: 19 border pixels of ~75 boundary ones).
struct DiscScene {
  Scene scene;
  std::vector<Disc> discs;
  std::vector<bool> complete;
};

DiscScene disc_scene(int W, int H, uint64_t seed = 5) {
  DiscScene d{flat(W, H), {}, {}};
  const double radii[4] = {10, 12, 14, 16};
  int n = 0;
  for (int cy = 30; cy + 30 <= H; cy += 40)
    for (int cx = 50; cx + 30 <= W; cx += 40) {
      d.discs.push_back({cx + 0.3 * (n % 3), cy + 0.2 * (n % 2), radii[n % 4]});
      d.complete.push_back(true);
      ++n;
    }
  d.discs.push_back({3.0, H / 2.0, 10});
  d.complete.push_back(false);
  for (const Disc& disc : d.discs) paint_disc(d.scene, disc, kStone);
  add_noise(d.scene, 0.04f, seed);
  return d;
}

int32_t particle_at(const ParticleAnalysis& a, double x, double y) {
  return a.components[size_t(int(y)) * a.width + size_t(int(x))];
}

void expect_discs_found(const DiscScene& d, const ParticleAnalysis& a) {
  ASSERT_EQ(a.particles.size(), d.discs.size());
  std::vector<bool> used(a.particles.size(), false);
  for (size_t k = 0; k < d.discs.size(); ++k) {
    const Disc& disc = d.discs[k];
    const int32_t id = particle_at(a, disc.cx < 0.5 ? 0.5 : disc.cx, disc.cy);
    ASSERT_GE(id, 0) << "disc " << k;
    EXPECT_FALSE(used[size_t(id)]) << "two discs in one particle";
    used[size_t(id)] = true;
    int64_t inter = 0, uni = 0;
    for (int y = 0; y < a.height; ++y)
      for (int x = 0; x < a.width; ++x) {
        const bool truth = disc.inside(x, y), found = a.components[size_t(y) * a.width + x] == id;
        inter += truth && found, uni += truth || found;
      }
    EXPECT_GE(double(inter) / double(uni), 0.98) << "disc " << k << " radius " << disc.r;
    EXPECT_EQ(a.particles[size_t(id)].complete, bool(d.complete[k])) << "disc " << k;
  }
}

ParticleAnalysisParams two_classes(double blur = 1.0) {
  ParticleAnalysisParams p;
  p.classes = 2;
  p.blur_sigma = blur;
  return p;
}

TEST(ParticlesAnalysis, DiscsOnFlatGroundAreFoundExactly) {
  const DiscScene d = disc_scene(256, 192);
  const ParticleAnalysis a = texsynth::analyse_particles(d.scene.view(), two_classes());
  EXPECT_EQ(a.num_classes, 2);
  EXPECT_EQ(a.classes[size_t(a.background)].particles, 0);
  ASSERT_NO_FATAL_FAILURE(expect_discs_found(d, a));
  // Class colour = the stone colour (noise averages out).
  const auto& stone = a.classes[size_t(1 - a.background)];
  EXPECT_NEAR(stone.colour[0], kStone.r, 0.01);
  EXPECT_NEAR(stone.colour[1], kStone.g, 0.01);
  EXPECT_EQ(stone.particles, int32_t(d.discs.size()));
  EXPECT_EQ(stone.complete, int32_t(d.discs.size()) - 1);
  EXPECT_TRUE(stone.has_complete);
  EXPECT_FALSE(stone.random);
  EXPECT_EQ(a.classes_without_complete, 0);
}

TEST(ParticlesAnalysis, NonSquareSampleWorks) {
  const DiscScene d = disc_scene(512, 256);
  const ParticleAnalysis a = texsynth::analyse_particles(d.scene.view(), two_classes());
  EXPECT_EQ(a.width, 512);
  EXPECT_EQ(a.height, 256);
  ASSERT_EQ(a.labels.size(), size_t(512) * 256);
  ASSERT_NO_FATAL_FAILURE(expect_discs_found(d, a));
  // Rows are not columns: a disc's centroid is where it was drawn, not transposed.
  const Disc& first = d.discs[0];
  const auto& p = a.particles[size_t(particle_at(a, first.cx, first.cy))];
  EXPECT_NEAR(p.centroid_x, first.cx, 0.3);
  EXPECT_NEAR(p.centroid_y, first.cy, 0.3);
}

// A 6 x 6 grid of 20 px squares, 8 px apart (pitch 28), 14 px margins: 188 x 188.
Scene square_grid() {
  Scene s = flat(188, 188);
  for (int j = 0; j < 6; ++j)
    for (int i = 0; i < 6; ++i) paint_rect(s, 14 + 28 * i, 14 + 28 * j, 20, 20, kStone);
  return s;
}

std::vector<CoOccurrence> entries(const ParticleAnalysis& a, int32_t id) {
  return std::vector<CoOccurrence>(a.cooc.begin() + a.cooc_start[size_t(id)], a.cooc.begin() + a.cooc_start[size_t(id) + 1]);
}

TEST(ParticlesAnalysis, SquareGridCoOccurrencesFollowTheGapConvention) {
  const Scene s = square_grid();
  const ParticleAnalysis a = texsynth::analyse_particles(s.view(), two_classes(0.0));
  ASSERT_EQ(a.particles.size(), 36u);
  auto square = [&](int i, int j) { return particle_at(a, 14 + 28 * i + 10, 14 + 28 * j + 10); };
  const int32_t me = square(2, 2);
  const auto& box = a.particles[size_t(me)].box;
  EXPECT_NEAR(box.half_x, 10.0, 1e-4);  // 20 px wide: the box holds every pixel square
  EXPECT_NEAR(box.angle, 0.0, 1e-6);
  // By hand: boxes are [x, x + 20]; a neighbour 28 px right has x-gap 28 - 20 = 8, and its y-extent
  // [0, 20] vs ours: gap on the + side (offset 0 counts as +) = 0 - 20 = -20. Diagonal: (8, 8).
  // All eight neighbours are 9 px away in Chebyshev distance (first hit at the same step), so each
  // quadrant keeps the two nearest centres: right (28) and up (28) in q0 (up has x offset 0 -> +),
  // left and up-left in q1, only down-left in q2 (left and down count as + on one axis), down and
  // down-right in q3.
  struct Want {
    int quadrant;
    float dx, dy;
    int i, j;
  };
  const Want want[] = {{0, 8, -20, 3, 2}, {0, -20, 8, 2, 3}, {1, 8, -20, 1, 2}, {1, 8, 8, 1, 3},
                       {2, 8, 8, 1, 1},   {3, -20, 8, 2, 1}, {3, 8, 8, 3, 1}};
  const auto got = entries(a, me);
  ASSERT_EQ(got.size(), std::size(want));
  for (size_t k = 0; k < got.size(); ++k) {
    SCOPED_TRACE("entry " + std::to_string(k));
    EXPECT_EQ(got[k].quadrant, want[k].quadrant);
    EXPECT_NEAR(got[k].dx, want[k].dx, 1e-4);
    EXPECT_NEAR(got[k].dy, want[k].dy, 1e-4);
    EXPECT_NEAR(got[k].angle, 0.0, 1e-6);
    EXPECT_EQ(got[k].neighbour, square(want[k].i, want[k].j));
    EXPECT_EQ(got[k].source, EntrySource::kMeasured);
  }
  // The bottom-left corner square sees neighbours in q0 only: q2 copies q0 (opposite); q1 and q3 have
  // empty opposites and take the class medians.
  const auto corner = entries(a, square(0, 0));
  int by_source[4][4] = {};
  for (const auto& e : corner) by_source[e.quadrant][int(e.source)]++;
  EXPECT_EQ(by_source[0][int(EntrySource::kMeasured)], 2);
  EXPECT_EQ(by_source[2][int(EntrySource::kOpposite)], 2);
  EXPECT_EQ(by_source[1][int(EntrySource::kClassMedian)], 1);
  EXPECT_EQ(by_source[3][int(EntrySource::kClassMedian)], 1);
  // Squares are apart: no overlap observed -> tolerance 0.1.
  EXPECT_NEAR(a.classes[size_t(1 - a.background)].tolerance, 0.1, 1e-12);
}

TEST(ParticlesAnalysis, DistanceTransformEqualsLiteralDilation) {
  const DiscScene discs = disc_scene(256, 192);
  const Scene grid = square_grid();
  Scene blobs = flat(160, 128);  // irregular blobs, tileable so that neighbours wrap
  texsynth::Rng rng(3);
  for (int k = 0; k < 30; ++k) {
    const double cx = rng.uniform() * 160, cy = rng.uniform() * 128;
    for (int m = 0; m < 3; ++m)
      paint_disc(blobs, {cx + 6 * rng.uniform(), cy + 6 * rng.uniform(), 2 + 5 * rng.uniform()}, kStone);
  }
  for (int wrap = 0; wrap < 2; ++wrap) {
    ParticleAnalysisParams p = two_classes(0.0);
    p.tileable = wrap == 1;
    for (const Scene* s : std::vector<const Scene*>{&discs.scene, &grid, &blobs}) {
      const ParticleAnalysis a = texsynth::analyse_particles(s->view(), p);
      ASSERT_GT(a.particles.size(), 5u);
      int hits = 0;
      for (int32_t id = 0; id < int32_t(a.particles.size()); ++id) {
        const auto fast = texsynth::particle_neighbours(a, id, false);
        const auto slow = texsynth::particle_neighbours(a, id, true);
        ASSERT_EQ(fast.size(), slow.size()) << "particle " << id;
        for (size_t k = 0; k < fast.size(); ++k) {
          EXPECT_EQ(fast[k].neighbour, slow[k].neighbour);
          EXPECT_EQ(fast[k].quadrant, slow[k].quadrant);
          EXPECT_EQ(fast[k].step, slow[k].step);
          EXPECT_EQ(fast[k].shift_x, slow[k].shift_x);
          EXPECT_EQ(fast[k].shift_y, slow[k].shift_y);
        }
        hits += int(fast.size());
      }
      EXPECT_GT(hits, 0);
    }
  }
}

TEST(ParticlesAnalysis, BorderCutFivePercentIsCompleteThirtyPercentIsNot) {
  Scene s = flat(128, 96);
  // Standing on the bottom edge. 6 x 56: ring of 2*6 + 2*56 - 4 = 120 boundary pixels, 6 on the
  // border (5 %). 30 x 22: 2*30 + 2*22 - 4 = 100 boundary pixels, 30 on the border (30 %).
  paint_rect(s, 20, 0, 6, 56, kStone);
  paint_rect(s, 60, 0, 30, 22, kStone);
  const ParticleAnalysis a = texsynth::analyse_particles(s.view(), two_classes(0.0));
  ASSERT_EQ(a.particles.size(), 2u);
  const auto& thin = a.particles[size_t(particle_at(a, 22, 30))];
  const auto& wide = a.particles[size_t(particle_at(a, 70, 10))];
  EXPECT_EQ(thin.boundary_pixels, 120);
  EXPECT_EQ(thin.border_pixels, 6);
  EXPECT_TRUE(thin.complete);
  EXPECT_EQ(wide.boundary_pixels, 100);
  EXPECT_EQ(wide.border_pixels, 30);
  EXPECT_FALSE(wide.complete);
  // Incomplete particles are never centres: no list.
  EXPECT_TRUE(entries(a, wide.id).empty());
}

TEST(ParticlesAnalysis, ClassWithoutCompleteParticleIsReportedNotThrown) {
  Scene s = flat(64, 64);
  paint_rect(s, 0, 10, 12, 12, kStone);  // 12 of 44 boundary pixels on the border
  const ParticleAnalysis a = texsynth::analyse_particles(s.view(), two_classes(0.0));
  ASSERT_EQ(a.particles.size(), 1u);
  EXPECT_FALSE(a.particles[0].complete);
  EXPECT_FALSE(a.classes[size_t(a.particles[0].class_id)].has_complete);
  EXPECT_EQ(a.classes_without_complete, 1);
  EXPECT_TRUE(a.classes[size_t(a.particles[0].class_id)].random);
  EXPECT_NEAR(a.classes[size_t(a.particles[0].class_id)].min_distance, 0.7 * 64, 1e-9);
}

TEST(ParticlesAnalysis, LabelImageReplacesKMeans) {
  const Scene s = flat(96, 64);  // one colour: k-means could not find anything
  ParticleAnalysisParams p;
  p.labels.assign(size_t(96) * 64, 0);
  auto rect = [&](int x0, int y0, int w, int h, int cls) {
    for (int y = y0; y < y0 + h; ++y)
      for (int x = x0; x < x0 + w; ++x) p.labels[size_t(y) * 96 + x] = cls;
  };
  rect(10, 10, 12, 12, 2);
  rect(40, 10, 12, 12, 2);
  rect(70, 30, 10, 20, 1);
  rect(5, 50, 2, 2, 1);  // 4 px < min area 16: merged into the background
  const ParticleAnalysis a = texsynth::analyse_particles(s.view(), p);
  EXPECT_EQ(a.num_classes, 3);
  EXPECT_EQ(a.background, 0);
  EXPECT_TRUE(a.centres.empty());
  ASSERT_EQ(a.particles.size(), 3u);
  EXPECT_EQ(a.particles[size_t(particle_at(a, 15, 15))].class_id, 2);
  EXPECT_EQ(a.particles[size_t(particle_at(a, 45, 15))].class_id, 2);
  EXPECT_EQ(a.particles[size_t(particle_at(a, 75, 40))].class_id, 1);
  EXPECT_EQ(a.merged_small, 1);
  EXPECT_EQ(a.labels[size_t(50) * 96 + 5], 0);
  EXPECT_EQ(a.classes[2].particles, 2);
  EXPECT_TRUE(a.classes[2].random);
  // Two particles 30 px apart (box centres): min distance 0.7 x 30.
  EXPECT_NEAR(a.classes[2].min_distance, 0.7 * 30, 1e-4);
  EXPECT_NEAR(a.classes[2].density, 2.0 / (96 * 64), 1e-12);
}

TEST(ParticlesAnalysis, TileableSampleJoinsParticleAcrossTheBorder) {
  Scene s = flat(96, 80);
  const Disc cut{0.0, 40.0, 12};  // half on each side of the left/right edge when wrapped
  Scene wrapped = s;
  int64_t area = 0;
  for (int y = 0; y < 80; ++y)
    for (int x = -20; x < 20; ++x)
      if (cut.inside(x, y)) wrapped.set((x + 96) % 96, y, kStone), ++area;
  ParticleAnalysisParams p = two_classes(0.0);
  const ParticleAnalysis plain = texsynth::analyse_particles(wrapped.view(), p);
  ASSERT_EQ(plain.particles.size(), 2u);
  EXPECT_FALSE(plain.particles[0].complete);
  EXPECT_FALSE(plain.particles[1].complete);
  p.tileable = true;
  const ParticleAnalysis tiled = texsynth::analyse_particles(wrapped.view(), p);
  ASSERT_EQ(tiled.particles.size(), 1u);
  const auto& one = tiled.particles[0];
  EXPECT_EQ(one.area, area);
  EXPECT_TRUE(one.complete);
  // Contiguous (unwrapped) extent: 24 px wide, centred on the edge.
  EXPECT_EQ(one.x1 - one.x0 + 1, 24);
  EXPECT_TRUE(std::abs(one.centroid_x - 0.0) < 0.6 || std::abs(one.centroid_x - 96.0) < 0.6) << one.centroid_x;
  // Its sprite is whole: alpha 1 on all its pixels.
  const auto sprite = texsynth::particle_sprite(tiled, wrapped.view(), 0);
  int64_t opaque = 0;
  for (int i = 0; i < sprite.width * sprite.height; ++i) opaque += sprite.rgba[size_t(i) * 4 + 3] == 1.f;
  EXPECT_EQ(opaque, area);
}

// The band of in-between colour that blurring draws around an element, as k-means classes it: discs ringed
// by a 1.5 px band of the colour halfway between disc and ground, a lone ring, a compact blob of the ring's
// colour against a bare disc (a berry on a pebble), and a thin red crescent hugging another bare disc (a
// berry half hidden by a pebble). Rims join their disc; the lone ring (nothing to join), the blob (not thin),
// the crescent (red is no mix of disc and ground) and a ring with a long tail (not a band along its disc)
// stay particles; a label image is taken as painted.
TEST(ParticlesAnalysis, BlurredRimsJoinTheirElementButPaintedClassesStay) {
  constexpr Colour kRim{0.5f, 0.5f, 0.28f};
  Scene s = flat(200, 96);
  std::vector<int32_t> painted(size_t(200) * 96, 0);
  auto paint = [&](const Disc& d, double inner, Colour c, int32_t label) {
    for (int y = 0; y < s.H; ++y)
      for (int x = 0; x < s.W; ++x) {
        const double r = std::hypot(x + 0.5 - d.cx, y + 0.5 - d.cy);
        if (r <= d.r && r > inner) s.set(x, y, c), painted[size_t(y) * 200 + x] = label;
      }
  };
  const Disc ringed[3] = {{25, 25, 10}, {65, 28, 12}, {30, 68, 9}};
  int64_t ringed_area[3] = {};
  for (int k = 0; k < 3; ++k) {
    paint({ringed[k].cx, ringed[k].cy, ringed[k].r + 1.5}, ringed[k].r, kRim, 2);
    paint(ringed[k], -1, kStone, 1);
    for (int y = 0; y < s.H; ++y)
      for (int x = 0; x < s.W; ++x) ringed_area[k] += std::hypot(x + 0.5 - ringed[k].cx, y + 0.5 - ringed[k].cy) <= ringed[k].r + 1.5;
  }
  paint({120, 25, 13.5}, 12, kRim, 2);  // a lone ring
  const Disc bare{115, 68, 11};
  paint(bare, -1, kStone, 1);
  paint({bare.cx + bare.r + 4, bare.cy, 4}, -1, kRim, 2);  // the blob's left edge touches the disc
  const Disc hidden{70, 70, 10};
  paint(hidden, -1, kStone, 1);
  for (int y = 0; y < s.H; ++y)
    for (int x = int(hidden.cx); x < s.W; ++x) {
      const double r = std::hypot(x + 0.5 - hidden.cx, y + 0.5 - hidden.cy);
      if (r > hidden.r && r <= hidden.r + 2) s.set(x, y, Colour{0.7f, 0.1f, 0.1f}), painted[size_t(y) * 200 + x] = 3;
    }
  // A ring whose tail runs 18 px away from its disc: not a band along the disc, so it stays a particle.
  const Disc tailed{165, 40, 9};
  paint({tailed.cx, tailed.cy, tailed.r + 1.5}, tailed.r, kRim, 2);
  paint(tailed, -1, kStone, 1);
  for (int y = 10; y < 30; ++y)
    for (int x = 164; x < 166; ++x) s.set(x, y, kRim), painted[size_t(y) * 200 + x] = 2;
  ParticleAnalysisParams p;
  p.classes = 4;
  p.blur_sigma = 0;
  const ParticleAnalysis a = texsynth::analyse_particles(s.view(), p);
  ASSERT_EQ(a.particles.size(), 10u)
      << "3 ringed discs, the lone ring, 2 bare discs, the blob, the crescent, the tailed ring and its disc";
  EXPECT_NE(particle_at(a, tailed.cx, tailed.cy), particle_at(a, 164.5, 15.5));
  const int32_t stone_class = a.particles[size_t(particle_at(a, bare.cx, bare.cy))].class_id;
  for (int k = 0; k < 3; ++k) {
    const auto& P = a.particles[size_t(particle_at(a, ringed[k].cx, ringed[k].cy))];
    EXPECT_EQ(P.area, ringed_area[k]) << "disc " << k << ": its rim joined it";
    EXPECT_EQ(P.class_id, stone_class) << "disc " << k;
    EXPECT_EQ(particle_at(a, ringed[k].cx + ringed[k].r + 0.5, ringed[k].cy), P.id) << "disc " << k;
    EXPECT_EQ(a.labels[size_t(ringed[k].cy) * 200 + size_t(ringed[k].cx + ringed[k].r + 0.5)], stone_class)
        << "a rim takes its disc's class";
  }
  const int32_t lone = particle_at(a, 120 + 12.8, 25), blob = particle_at(a, bare.cx + bare.r + 4, bare.cy);
  ASSERT_GE(lone, 0);
  ASSERT_GE(blob, 0);
  EXPECT_NE(a.particles[size_t(lone)].class_id, stone_class);
  EXPECT_NE(a.particles[size_t(blob)].class_id, stone_class);
  EXPECT_NE(blob, particle_at(a, bare.cx, bare.cy));
  const int32_t crescent = particle_at(a, hidden.cx + hidden.r + 1, hidden.cy);
  ASSERT_GE(crescent, 0);
  EXPECT_NE(crescent, particle_at(a, hidden.cx, hidden.cy));
  EXPECT_EQ(a.particles[size_t(particle_at(a, hidden.cx, hidden.cy))].class_id, stone_class);

  ParticleAnalysisParams labelled;
  labelled.labels = painted;
  labelled.background = 0;
  const ParticleAnalysis b = texsynth::analyse_particles(s.view(), labelled);
  EXPECT_EQ(b.particles.size(), 13u) << "painted rims are particles of their own";
}

// A disc across the left/right edge of a tileable sample, rimmed on its left half only: the rim, found from
// the right edge, joins the disc, found from the left one, in one frame (the unwrapped particle is as wide as
// the rimmed disc, not a sample width).
TEST(ParticlesAnalysis, RimAcrossTheBorderOfATileableSampleJoinsItsDiscInOneFrame) {
  constexpr Colour kRim{0.5f, 0.5f, 0.28f};
  Scene s = flat(96, 80);
  int64_t area = 0;
  int x_min = 1000, x_max = -1000;
  for (int y = 0; y < 80; ++y)
    for (int x = -20; x < 20; ++x) {
      const double r = std::hypot(x + 0.5 - 0.0, y + 0.5 - 40.0);
      if (r > 13.5 || (r > 12 && x >= 0)) continue;
      s.set((x + 96) % 96, y, r <= 12 ? kStone : kRim);
      ++area, x_min = std::min(x_min, x), x_max = std::max(x_max, x);
    }
  ParticleAnalysisParams p;
  p.classes = 3;
  p.blur_sigma = 0;
  p.tileable = true;
  const ParticleAnalysis a = texsynth::analyse_particles(s.view(), p);
  ASSERT_EQ(a.particles.size(), 1u);
  EXPECT_EQ(a.particles[0].area, area);
  EXPECT_EQ(a.particles[0].x1 - a.particles[0].x0, x_max - x_min);
  EXPECT_TRUE(a.particles[0].complete);
  p.tileable = false;
  const ParticleAnalysis cut = texsynth::analyse_particles(s.view(), p);
  ASSERT_EQ(cut.particles.size(), 2u) << "one half on each side, the left one with its rim";
  EXPECT_EQ(cut.particles[0].area + cut.particles[1].area, area);
}

// The add-on's detected repeat (texture_particles.md "Tileable samples"): wrap_blur = false keeps the classes
// of the untiled analysis (k-means sees the same blurred pixels) and still joins particles across the border.
TEST(ParticlesAnalysis, ClampedBlurKeepsTheUntiledClassesAndStillWrapsParticles) {
  Scene s = flat(96, 80);
  int64_t area = 0;
  const Disc across{0.0, 40.0, 12};  // half on each side of the left/right edge when wrapped
  for (int y = 0; y < 80; ++y)
    for (int x = -20; x < 20; ++x)
      if (across.inside(x, y)) s.set((x + 96) % 96, y, kStone), ++area;
  paint_disc(s, Disc{48.0, 79.0, 9}, kStone);  // cut by the top edge only: wrapping blurs it into the bottom rows
  ParticleAnalysisParams p = two_classes(2.0);
  const ParticleAnalysis plain = texsynth::analyse_particles(s.view(), p);
  ASSERT_EQ(plain.particles.size(), 3u);
  p.tileable = true;
  p.wrap_blur = false;
  const ParticleAnalysis clamped = texsynth::analyse_particles(s.view(), p);
  EXPECT_EQ(clamped.centres, plain.centres);
  EXPECT_EQ(clamped.labels, plain.labels);
  ASSERT_EQ(clamped.particles.size(), 2u);
  const int32_t joined = particle_at(clamped, 1.0, 40.0);
  ASSERT_GE(joined, 0);
  EXPECT_TRUE(clamped.particles[size_t(joined)].complete);
  EXPECT_NEAR(double(clamped.particles[size_t(joined)].area), double(area), 0.1 * double(area));
  p.wrap_blur = true;  // the blur across the border moves the centres: the case wrap_blur = false avoids
  const ParticleAnalysis wrapped = texsynth::analyse_particles(s.view(), p);
  EXPECT_NE(wrapped.centres, plain.centres);
}

TEST(ParticlesAnalysis, OneRowSampleStillFillsEveryQuadrant) {
  Scene s = flat(176, 48);  // 7 squares of 16 px, 8 px apart, in one row
  for (int i = 0; i < 7; ++i) paint_rect(s, 8 + 24 * i, 16, 16, 16, kStone);
  const ParticleAnalysis a = texsynth::analyse_particles(s.view(), two_classes(0.0));
  ASSERT_EQ(a.particles.size(), 7u);
  for (int i = 0; i < 7; ++i) {
    SCOPED_TRACE("square " + std::to_string(i));
    const int32_t id = particle_at(a, 8 + 24 * i + 8, 24);
    EXPECT_TRUE(a.particles[size_t(id)].complete);
    EXPECT_EQ(a.particles[size_t(id)].id, i);  // ids in row-major first-pixel order: left to right
    int count[4] = {};
    EntrySource source[4] = {};
    for (const auto& e : entries(a, id)) {
      count[e.quadrant]++;
      source[e.quadrant] = e.source;
      // Every entry, measured or filled, is a neighbour 8 px along the row: (8, -16) by hand.
      EXPECT_NEAR(e.dx, 8, 1e-4);
      EXPECT_NEAR(e.dy, -16, 1e-4);
    }
    for (int q = 0; q < 4; ++q) EXPECT_EQ(count[q], 1) << "quadrant " << q;
    // Right neighbours fall in q0 (y offset 0 counts as +), left ones in q1.
    EXPECT_EQ(source[0], i < 6 ? EntrySource::kMeasured : EntrySource::kClassMedian);
    EXPECT_EQ(source[1], i > 0 ? EntrySource::kMeasured : EntrySource::kClassMedian);
    EXPECT_EQ(source[2], i < 6 ? EntrySource::kOpposite : EntrySource::kAdjacent);
    EXPECT_EQ(source[3], i > 0 ? EntrySource::kOpposite : EntrySource::kAdjacent);
  }
}

TEST(ParticlesAnalysis, OrientedBoxFollowsARotatedBar) {
  Scene s = flat(128, 128);
  const double t = 30 * 3.14159265358979 / 180, c = std::cos(t), sn = std::sin(t);
  for (int y = 0; y < 128; ++y)
    for (int x = 0; x < 128; ++x) {
      const double dx = x + 0.5 - 64, dy = y + 0.5 - 64;
      if (std::abs(dx * c + dy * sn) <= 20 && std::abs(-dx * sn + dy * c) <= 5) s.set(x, y, kStone);
    }
  const ParticleAnalysis a = texsynth::analyse_particles(s.view(), two_classes(0.0));
  ASSERT_EQ(a.particles.size(), 1u);
  const auto& b = a.particles[0].box;
  EXPECT_NEAR(b.angle * 180 / 3.14159265358979, 30.0, 2.0);
  EXPECT_NEAR(b.half_x, 20.0, 1.0);
  EXPECT_NEAR(b.half_y, 5.0, 1.0);
  EXPECT_NEAR(b.cx, 64.0, 0.5);
  EXPECT_NEAR(b.cy, 64.0, 0.5);
}

// Bars at 30 deg in staggered rows, cut by every border: the cut ones' visible parts have other boxes.
TEST(ParticlesAnalysis, EntriesTowardsCutNeighboursKeepTheClassAngle) {
  Scene s = flat(200, 200);
  const double t = 30 * 3.14159265358979 / 180, c = std::cos(t), sn = std::sin(t);
  std::vector<std::pair<double, double>> centres;
  for (int row = -12; row <= 12; ++row)
    for (int col = -12; col <= 12; ++col) {
      const double along = col * 34.0 + (row % 2 ? 17.0 : 0.0), across = row * 16.0;
      centres.push_back({100 + along * c - across * sn, 100 + along * sn + across * c});
    }
  for (int y = 0; y < 200; ++y)
    for (int x = 0; x < 200; ++x)
      for (const auto& [cx, cy] : centres) {
        const double dx = x + 0.5 - cx, dy = y + 0.5 - cy;
        if (std::abs(dx * c + dy * sn) <= 13 && std::abs(-dx * sn + dy * c) <= 4) s.set(x, y, kStone);
      }
  const ParticleAnalysis a = texsynth::analyse_particles(s.view(), two_classes(0.0));
  int towards_cut = 0, total = 0;
  for (size_t i = 0; i < a.particles.size(); ++i)
    for (const CoOccurrence& e : entries(a, int32_t(i))) {
      ++total;
      if (e.neighbour >= 0 && !a.particles[size_t(e.neighbour)].complete) ++towards_cut;
      EXPECT_NEAR(e.angle * 180 / 3.14159265358979, 0.0, 3.0) << "particle " << i;
    }
  EXPECT_GT(towards_cut, 10) << "the sample must have entries towards cut bars, of " << total;
  EXPECT_FALSE(a.classes[size_t(a.particles[0].class_id)].random);
}

// Dots scattered far apart (>= 36 px, radius 4: the dilation cap is 13.5 px) are placed at random, not
// packed at the gaps of the few close pairs; the lattice of discs is not.
TEST(ParticlesAnalysis, ScatteredDotsAreARandomClassALatticeIsNot) {
  Scene s = flat(320, 320);
  texsynth::Rng rng(3);
  std::vector<Disc> dots;
  for (int tries = 0; tries < 4000 && dots.size() < 40; ++tries) {
    const Disc d{12 + 296 * rng.uniform(), 12 + 296 * rng.uniform(), 4.0};
    bool far = true;
    for (const Disc& o : dots) far = far && std::hypot(d.cx - o.cx, d.cy - o.cy) >= 36;
    if (far) dots.push_back(d);
  }
  ASSERT_GE(dots.size(), 30u);
  for (const Disc& d : dots) paint_disc(s, d, kStone);
  const ParticleAnalysis scattered = texsynth::analyse_particles(s.view(), two_classes());
  ASSERT_EQ(scattered.particles.size(), dots.size());
  EXPECT_TRUE(scattered.classes[size_t(scattered.particles[0].class_id)].random);

  const DiscScene lattice = disc_scene(256, 192);
  const ParticleAnalysis a = texsynth::analyse_particles(lattice.scene.view(), two_classes());
  EXPECT_FALSE(a.classes[size_t(a.particles[0].class_id)].random);
}

double psnr(const std::vector<float>& a, const std::vector<float>& b) {
  double se = 0;
  for (size_t i = 0; i < a.size(); ++i) se += double(a[i] - b[i]) * double(a[i] - b[i]);
  return 10 * std::log10(1.0 / std::max(se / double(a.size()), 1e-20));
}

TEST(ParticlesAnalysis, BackgroundFillAndRecompositionFromSprites) {
  const DiscScene d = disc_scene(256, 192);
  const Scene& s = d.scene;
  const ParticleAnalysis a = texsynth::analyse_particles(s.view(), two_classes());
  // Background mean from the truth: pixels outside every disc.
  double mean[3] = {0, 0, 0};
  int64_t n = 0;
  for (int y = 0; y < s.H; ++y)
    for (int x = 0; x < s.W; ++x) {
      bool in = false;
      for (const Disc& disc : d.discs) in |= disc.inside(x, y);
      if (in) continue;
      for (int c = 0; c < 3; ++c) mean[c] += s.px[(size_t(y) * s.W + x) * 3 + c];
      ++n;
    }
  for (double& m : mean) m /= double(n);
  // Every pixel of the fill (filled or kept) is ground: within the noise (0.04) of the mean.
  int64_t filled = 0;
  double worst = 0;
  for (int y = 0; y < s.H; ++y)
    for (int x = 0; x < s.W; ++x) {
      const size_t i = size_t(y) * s.W + x;
      bool changed = false;
      for (int c = 0; c < 3; ++c) {
        changed |= a.background_fill[i * 3 + c] != s.px[i * 3 + c];
        worst = std::max(worst, std::abs(a.background_fill[i * 3 + c] - mean[c]));
      }
      filled += changed;
    }
  EXPECT_GT(filled, 20 * 314);  // the discs' pixels were replaced
  EXPECT_LT(worst, 0.05);
  // Recompose: every sprite "over" the filled background, in place.
  std::vector<float> out = a.background_fill;
  for (int32_t id = 0; id < int32_t(a.particles.size()); ++id) {
    const auto sp = texsynth::particle_sprite(a, s.view(), id);
    for (int y = 0; y < sp.height; ++y)
      for (int x = 0; x < sp.width; ++x) {
        const int gx = sp.x0 + x, gy = sp.y0 + y;
        if (gx < 0 || gy < 0 || gx >= s.W || gy >= s.H) continue;
        const float* src = &sp.rgba[(size_t(y) * sp.width + x) * 4];
        float* dst = &out[(size_t(gy) * s.W + gx) * 3];
        for (int c = 0; c < 3; ++c) dst[c] = src[3] * src[c] + (1 - src[3]) * dst[c];
      }
  }
  EXPECT_GE(psnr(out, s.px), 30.0);
  // And the fill alone is far from the sample (the test above can fail).
  EXPECT_LT(psnr(a.background_fill, s.px), 30.0);
}

TEST(ParticlesAnalysis, SpriteAlphaRampsOverTwoPixels) {
  Scene s = flat(64, 64);
  paint_rect(s, 20, 20, 10, 10, kStone);
  const ParticleAnalysis a = texsynth::analyse_particles(s.view(), two_classes(0.0));
  ASSERT_EQ(a.particles.size(), 1u);
  const auto sp = texsynth::particle_sprite(a, s.view(), 0);
  EXPECT_EQ(sp.width, 14);
  EXPECT_EQ(sp.x0, 18);
  auto alpha = [&](int x, int y) { return sp.rgba[(size_t(y) * sp.width + x) * 4 + 3]; };
  EXPECT_EQ(alpha(7, 7), 1.f);             // inside
  EXPECT_NEAR(alpha(1, 7), 2.0 / 3, 1e-6);  // 1 px left of the mask
  EXPECT_NEAR(alpha(0, 7), 1.0 / 3, 1e-6);  // 2 px
  EXPECT_NEAR(alpha(0, 0), 1 - std::sqrt(8.0) / 3, 1e-6);  // diagonal corner, 2.83 px
  EXPECT_NEAR(sp.rgba[(size_t(7) * sp.width + 7) * 4 + 0], kStone.r, 1e-6);
}

void expect_same(const ParticleAnalysis& a, const ParticleAnalysis& b) {
  EXPECT_EQ(a.labels, b.labels);
  EXPECT_EQ(a.components, b.components);
  EXPECT_EQ(a.centres, b.centres);
  EXPECT_EQ(a.background_fill, b.background_fill);
  ASSERT_EQ(a.particles.size(), b.particles.size());
  EXPECT_EQ(0, std::memcmp(a.particles.data(), b.particles.data(), a.particles.size() * sizeof(a.particles[0])));
  EXPECT_EQ(a.cooc_start, b.cooc_start);
  ASSERT_EQ(a.cooc.size(), b.cooc.size());
  for (size_t i = 0; i < a.cooc.size(); ++i) {
    EXPECT_EQ(a.cooc[i].quadrant, b.cooc[i].quadrant);
    EXPECT_EQ(std::memcmp(&a.cooc[i].dx, &b.cooc[i].dx, 3 * sizeof(float)), 0);
    EXPECT_EQ(a.cooc[i].neighbour, b.cooc[i].neighbour);
    EXPECT_EQ(a.cooc[i].source, b.cooc[i].source);
  }
  for (size_t k = 0; k < a.classes.size(); ++k) {
    EXPECT_EQ(a.classes[k].tolerance, b.classes[k].tolerance);
    EXPECT_EQ(a.classes[k].density, b.classes[k].density);
  }
  ASSERT_EQ(a.class_pairs.size(), b.class_pairs.size());
  for (size_t k = 0; k < a.class_pairs.size(); ++k) {
    EXPECT_EQ(a.class_pairs[k].pairs, b.class_pairs[k].pairs);
    EXPECT_EQ(a.class_pairs[k].tolerance, b.class_pairs[k].tolerance);
    EXPECT_EQ(a.class_pairs[k].margin, b.class_pairs[k].margin);
  }
}

TEST(ParticlesAnalysis, SameBytesAtOneAndTwoThreads) {
  // 320 x 256 = 81,920 pixels: k-means fits a subsample; k = 4 splits the noise too.
  const DiscScene d = disc_scene(320, 256);
  ParticleAnalysisParams p;
  p.seed = 17;
  ParticleAnalysis one, two;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    one = texsynth::analyse_particles(d.scene.view(), p);
  }
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
    two = texsynth::analyse_particles(d.scene.view(), p);
  }
  ASSERT_GT(one.particles.size(), 10u);
  expect_same(one, two);
  // Another seed changes the fill (the hash picks other neighbours).
  p.seed = 18;
  const ParticleAnalysis other = texsynth::analyse_particles(d.scene.view(), p);
  EXPECT_NE(one.background_fill, other.background_fill);
}

void expect_refused(const texsynth::ParticleSample& s, const ParticleAnalysisParams& p, const std::string& words) {
  try {
    texsynth::analyse_particles(s, p);
    ADD_FAILURE() << "accepted; expected a refusal mentioning '" << words << "'";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
  }
}

TEST(ParticlesAnalysis, BadInputIsRefusedClearly) {
  Scene s = flat(32, 24);
  ParticleAnalysisParams p;
  expect_refused({s.px.data(), 32, 24, 2}, p, "3 or 4 channels");
  expect_refused({nullptr, 32, 24, 3}, p, "missing");
  expect_refused({s.px.data(), 32, 4, 3}, p, "too small");
  Scene nan = s;
  nan.px[(size_t(5) * 32 + 7) * 3 + 1] = std::numeric_limits<float>::quiet_NaN();
  expect_refused(nan.view(), p, "(7, 5) is NaN");
  p.classes = 1;
  expect_refused(s.view(), p, "classes must be in 2..12");
  p.classes = 13;
  expect_refused(s.view(), p, "classes must be in 2..12");
  p.classes = 4;
  p.blur_sigma = -1;
  expect_refused(s.view(), p, "blur");
  p.blur_sigma = 1;
  p.labels.assign(32 * 23, 0);
  expect_refused(s.view(), p, "label image has 736 values, expected width x height = 768");
  p.labels.assign(32 * 24, 0);
  p.labels[40] = -2;
  expect_refused(s.view(), p, "label at pixel (8, 1) is -2");
  p.labels.clear();
  p.background = 4;
  expect_refused(s.view(), p, "background class 4 is out of range");
  p.background = -1;
  p.min_area = -3;
  expect_refused(s.view(), p, "min_area");
  p.min_area = 0;
  const ParticleAnalysis a = texsynth::analyse_particles(s.view(), p);
  EXPECT_THROW(texsynth::particle_sprite(a, s.view(), 0), std::invalid_argument);  // no particles
  EXPECT_THROW(texsynth::particle_neighbours(a, -1), std::invalid_argument);
}

TEST(ParticlesAnalysis, SpriteRefusesAnotherSample) {
  Scene s = flat(64, 64);
  paint_rect(s, 20, 20, 10, 10, kStone);
  const ParticleAnalysis a = texsynth::analyse_particles(s.view(), two_classes(0.0));
  const Scene other = flat(64, 48);
  EXPECT_THROW(texsynth::particle_sprite(a, other.view(), 0), std::invalid_argument);
}

TEST(ParticlesAnalysis, RaisedCancelFlagThrowsCancelled) {
  const DiscScene d = disc_scene(256, 192);
  std::atomic<bool> flag{true};
  std::atomic<float> progress{0};
  ParticleAnalysisParams p = two_classes();
  p.cancel = &flag;
  EXPECT_THROW(texsynth::analyse_particles(d.scene.view(), p), texsynth::Cancelled);
  flag = false;
  p.progress = &progress;
  texsynth::analyse_particles(d.scene.view(), p);
  EXPECT_EQ(progress.load(), 1.f);
}

}  // namespace
