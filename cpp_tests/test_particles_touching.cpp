// SPDX-License-Identifier: GPL-3.0-or-later
// Touching elements (particles/analysis.hpp, conventions "Touching elements"; issue 30): the distance-transform
// watershed splits discs that touch, leaves one ellipse whole, and is safe on degenerate inputs.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "particle_fixtures.hpp"
#include "texsynth/common/rng.hpp"
#include "texsynth/particles/analysis.hpp"

namespace {

using texsynth::ParticleAnalysis;
using texsynth::ParticleAnalysisParams;

using particle_fixtures::add_noise;
using particle_fixtures::flat;
using particle_fixtures::Scene;

// Ellipse (centre, half axes, angle in radians), wrapped around the sample when tileable.
void paint_ellipse(Scene& s, double cx, double cy, double a, double b, double angle, float v, bool wrap = false) {
  const double c = std::cos(angle), sn = std::sin(angle);
  for (int y = 0; y < s.H; ++y)
    for (int x = 0; x < s.W; ++x) {
      double dx = x + 0.5 - cx, dy = y + 0.5 - cy;
      if (wrap) dx -= s.W * std::round(dx / s.W), dy -= s.H * std::round(dy / s.H);
      const double u = (dx * c + dy * sn) / a, w = (-dx * sn + dy * c) / b;
      if (u * u + w * w <= 1) s.set(x, y, v);
    }
}

ParticleAnalysisParams touching_params(int classes = 2) {
  ParticleAnalysisParams p;
  p.classes = classes;
  p.blur_sigma = 0;
  p.touching = true;
  return p;
}

int32_t particle_at(const ParticleAnalysis& a, double x, double y) {
  return a.components[size_t(int(y)) * size_t(a.width) + size_t(int(x))];
}

TEST(ParticlesTouching, TwoTouchingDiscsAreSplitInTwo) {
  Scene s = flat(96, 64, 0.25f);
  paint_ellipse(s, 38, 32, 12, 12, 0, 0.7f);  // centres 20 px apart: a neck 2 x 6.6 px wide
  paint_ellipse(s, 58, 32, 12, 12, 0, 0.7f);
  ParticleAnalysisParams plain;
  plain.classes = 2, plain.blur_sigma = 0;
  const ParticleAnalysis before = texsynth::analyse_particles(s.view(), plain);
  ASSERT_EQ(before.particles.size(), 1u);
  const ParticleAnalysis a = texsynth::analyse_particles(s.view(), touching_params());
  ASSERT_EQ(a.particles.size(), 2u);
  const int32_t left = particle_at(a, 32, 32), right = particle_at(a, 64, 32);
  ASSERT_GE(left, 0);
  ASSERT_GE(right, 0);
  EXPECT_NE(left, right);
  // Mirror images: the split runs along the symmetry line, give or take the chamfer's pixel.
  EXPECT_NEAR(a.particles[size_t(left)].area, a.particles[size_t(right)].area, 0.05 * before.particles[0].area);
  EXPECT_EQ(a.particles[0].area + a.particles[1].area, before.particles[0].area);
  EXPECT_NEAR(a.particles[size_t(left)].centroid_x, 37.0, 1.5);
  EXPECT_NEAR(a.particles[size_t(right)].centroid_x, 59.0, 1.5);
}

TEST(ParticlesTouching, DiscsTouchingAcrossATileableBorderAreSplit) {
  Scene s = flat(64, 64, 0.25f);
  paint_ellipse(s, 54, 20, 11, 11, 0, 0.7f, true);
  paint_ellipse(s, 72, 20, 11, 11, 0, 0.7f, true);  // = x 8, across the seam
  ParticleAnalysisParams p = touching_params();
  p.tileable = true;
  const ParticleAnalysis a = texsynth::analyse_particles(s.view(), p);
  ASSERT_EQ(a.particles.size(), 2u);
  EXPECT_NE(particle_at(a, 50, 20), particle_at(a, 10, 20));
}

TEST(ParticlesTouching, OneEllipseIsNotSplit) {
  for (double angle : {0.0, 0.5, 1.2}) {
    for (double aspect : {1.0, 2.0, 3.0}) {
      Scene s = flat(128, 128, 0.25f);
      paint_ellipse(s, 64, 64, 36, 36 / aspect, angle, 0.7f);
      add_noise(s, 0.05f, 3);
      const ParticleAnalysis a = texsynth::analyse_particles(s.view(), touching_params());
      EXPECT_EQ(a.particles.size(), 1u) << "angle " << angle << " aspect " << aspect;
    }
  }
}

TEST(ParticlesTouching, ShadowsDarkerThanTheGroundJoinIt) {
  // Three discs in a row, each with a darker shadow ring, the rings touching: the lace is the ground, the
  // shadow class is darker, so it joins the background, and the three discs come out whole.
  Scene s = flat(128, 64, 0.45f);
  for (double cx : {30.0, 62.0, 94.0}) paint_ellipse(s, cx, 32, 16.5, 16.5, 0, 0.15f);
  for (double cx : {30.0, 62.0, 94.0}) paint_ellipse(s, cx, 32, 12, 12, 0, 0.8f);
  const ParticleAnalysis a = texsynth::analyse_particles(s.view(), touching_params(3));
  ASSERT_EQ(a.particles.size(), 3u);
  for (const auto& p : a.particles) EXPECT_NEAR(p.area, M_PI * 144, 0.1 * M_PI * 144);
  ParticleAnalysisParams keep = touching_params(3);
  keep.touching_darker = false;
  const ParticleAnalysis b = texsynth::analyse_particles(s.view(), keep);
  EXPECT_GE(b.particles.size(), 1u);  // the rings stay foreground: one joined piece or rings and cores
}

TEST(ParticlesTouching, ShadingSplitsAtADarkSeamTheDistanceCannotSee) {
  // A 48 x 20 px bar given as a label image, lit, with a dark 2 px seam across its middle: the distance alone
  // sees one bar; with shading the seam is a saddle and the bar two elements.
  Scene s = flat(80, 40, 0.3f);
  ParticleAnalysisParams p = touching_params();
  p.labels.assign(size_t(s.W) * s.H, 0);
  p.background = 0;
  for (int y = 10; y < 30; ++y)
    for (int x = 16; x < 64; ++x) {
      p.labels[size_t(y) * s.W + x] = 1;
      s.set(x, y, x == 39 || x == 40 ? 0.1f : 0.75f);
    }
  EXPECT_EQ(texsynth::analyse_particles(s.view(), p).particles.size(), 1u);
  p.touching_shading = 1;
  const ParticleAnalysis a = texsynth::analyse_particles(s.view(), p);
  ASSERT_EQ(a.particles.size(), 2u);
  EXPECT_NE(particle_at(a, 30, 20), particle_at(a, 50, 20));
  EXPECT_NEAR(a.particles[0].area, a.particles[1].area, 40);
}

// touching_auto: the split where one plain particle spans more than a fifth of the sample, the plain components
// elsewhere, and the plain ones again when the split would leave a smaller share of complete particles.
double complete_share(const ParticleAnalysis& a) {
  int64_t whole = 0;
  for (const auto& p : a.particles) whole += p.complete;
  return a.particles.empty() ? 0.0 : double(whole) / double(a.particles.size());
}

TEST(ParticlesTouching, AutoSplitsWhereOneRegionSpansTheSample) {
  Scene s = flat(80, 64, 0.25f);
  paint_ellipse(s, 27, 32, 16, 16, 0, 0.7f);  // joined: ~1,600 of 5,120 px (31 %)
  paint_ellipse(s, 53, 32, 16, 16, 0, 0.7f);
  ParticleAnalysisParams p;
  p.classes = 2, p.blur_sigma = 0, p.touching_auto = true;
  const ParticleAnalysis a = texsynth::analyse_particles(s.view(), p);
  EXPECT_TRUE(a.touching);
  ASSERT_EQ(a.particles.size(), 2u);
  EXPECT_EQ(a.components, texsynth::analyse_particles(s.view(), touching_params()).components);
}

TEST(ParticlesTouching, AutoLeavesSeparatedElementsAsTheyAre) {
  Scene s = flat(96, 64, 0.25f);
  paint_ellipse(s, 38, 32, 12, 12, 0, 0.7f);  // the touching pair of above at 15 % of the sample: not split
  paint_ellipse(s, 58, 32, 12, 12, 0, 0.7f);
  paint_ellipse(s, 84, 12, 5, 5, 0, 0.7f);
  ParticleAnalysisParams p;
  p.classes = 2, p.blur_sigma = 0;
  const ParticleAnalysis plain = texsynth::analyse_particles(s.view(), p);
  p.touching_auto = true;
  const ParticleAnalysis a = texsynth::analyse_particles(s.view(), p);
  EXPECT_FALSE(a.touching);
  EXPECT_EQ(a.particles.size(), 2u);
  EXPECT_EQ(a.components, plain.components);
  EXPECT_EQ(a.labels, plain.labels);
}

// Four separate leaves, each with a rim and a vein along its length in a third colour (fallen_leaves in the
// corpus): no region spans a fifth of the sample, but the plain particles are two halves and a rim with its
// vein per leaf, lying against each other, of very different sizes. Auto keeps the split, which gives each leaf
// whole; without rims and veins it stays plain.
Scene veined_leaves(bool veins) {
  Scene s = flat(128, 96, 0.25f);
  const double centres[4][2] = {{30, 24}, {94, 24}, {30, 72}, {94, 72}};
  for (const auto& c : centres) {
    paint_ellipse(s, c[0], c[1], 18, 9, 0, veins ? 0.5f : 0.7f);  // the rim, in the veins' colour
    paint_ellipse(s, c[0], c[1], 16.5, 7.5, 0, 0.7f);
    if (veins)
      for (int x = int(c[0]) - 19; x <= int(c[0]) + 19; ++x)
        for (int y = int(c[1]) - 1; y <= int(c[1]) + 1; ++y) s.set(x, y, 0.5f);
  }
  return s;
}

TEST(ParticlesTouching, AutoJoinsTheFragmentsOfElementsCutByTheirVeins) {
  ParticleAnalysisParams p;
  p.classes = 3, p.blur_sigma = 0;
  const Scene s = veined_leaves(true);
  const ParticleAnalysis plain = texsynth::analyse_particles(s.view(), p);
  ASSERT_EQ(plain.particles.size(), 12u) << "classes: " << plain.num_classes << ", background " << plain.background;
  p.touching_auto = true;
  const ParticleAnalysis a = texsynth::analyse_particles(s.view(), p);
  EXPECT_TRUE(a.touching);
  EXPECT_TRUE(a.touching_fragments);
  ASSERT_EQ(a.particles.size(), 4u);
  for (const auto& part : a.particles) EXPECT_GT(part.area, 450);  // the whole leaf, vein included (~500 px)
  const int32_t leaf = particle_at(a, 30, 30);
  EXPECT_GE(leaf, 0);
  EXPECT_EQ(particle_at(a, 30, 18), leaf);  // both halves and the vein in one particle
  EXPECT_EQ(particle_at(a, 30, 23.5), leaf);

  const Scene plain_leaves = veined_leaves(false);
  const ParticleAnalysis without = texsynth::analyse_particles(plain_leaves.view(), p);
  EXPECT_FALSE(without.touching);
  EXPECT_FALSE(without.touching_fragments);
  EXPECT_EQ(without.particles.size(), 4u);
}

// Separate elements of two kinds, large grey stones and small red berries (blend_samples/pebbles.png): their
// sizes differ as fragments' do, and the split, which drops the berries as too thin, would make them more
// uniform; but they lie on the ground, not against each other, so Auto does not try it and keeps the berries.
TEST(ParticlesTouching, AutoKeepsSmallSeparateElementsOfAnotherKind) {
  Scene s = flat(128, 96, 0.25f);
  for (int i = 0; i < 4; ++i) paint_ellipse(s, 20 + 30 * i, 26, 11, 11, 0, 0.7f);
  for (int i = 0; i < 8; ++i) paint_ellipse(s, 10 + 15 * i, 70, 3, 3, 0, 0.5f);
  ParticleAnalysisParams p;
  p.classes = 3, p.blur_sigma = 0;
  const ParticleAnalysis plain = texsynth::analyse_particles(s.view(), p);
  ASSERT_EQ(plain.particles.size(), 12u);
  p.touching_auto = true;
  const ParticleAnalysis a = texsynth::analyse_particles(s.view(), p);
  EXPECT_FALSE(a.touching);
  EXPECT_EQ(a.particles.size(), 12u);
  EXPECT_EQ(a.components, plain.components);
}

TEST(ParticlesTouching, AutoKeepsThePlainComponentsWhenTheSplitCutsMoreAtTheBorder) {
  // A dark frame along the (not tileable) border, 44 % of the sample, around a light field with four dark
  // dots: plain, the frame is one cut particle and the dots are whole; the split cuts the frame at its
  // corners' distance peaks and drops the thin dots, so fewer of its particles are whole.
  Scene s = flat(96, 96, 0.7f);
  for (int y = 0; y < 96; ++y)
    for (int x = 0; x < 96; ++x)
      if (x < 12 || y < 12 || x >= 84 || y >= 84) s.set(x, y, 0.25f);
  for (const auto& [cx, cy] : {std::pair{34.0, 34.0}, {62.0, 34.0}, {34.0, 62.0}, {62.0, 62.0}})
    paint_ellipse(s, cx, cy, 4, 4, 0, 0.25f);
  ParticleAnalysisParams p;
  p.classes = 2, p.blur_sigma = 0;
  const ParticleAnalysis plain = texsynth::analyse_particles(s.view(), p);
  ASSERT_EQ(plain.particles.size(), 5u);
  const ParticleAnalysis forced = texsynth::analyse_particles(s.view(), touching_params());
  ASSERT_LT(complete_share(forced), complete_share(plain));  // what the guard is for
  p.touching_auto = true;
  const ParticleAnalysis a = texsynth::analyse_particles(s.view(), p);
  EXPECT_FALSE(a.touching);
  EXPECT_EQ(a.components, plain.components);
}

TEST(ParticlesTouching, DegenerateInputsAreSafe) {
  const int W = 8, H = 8;
  Scene s = flat(W, H, 0.5f);
  // Uniform sample: one class holds every pixel and is the background: no particle.
  EXPECT_TRUE(texsynth::analyse_particles(s.view(), touching_params()).particles.empty());
  // Every pixel foreground (labels all 1, background 0 given): no background to measure from, one particle.
  ParticleAnalysisParams all = touching_params();
  all.labels.assign(size_t(W) * H, 1);
  all.background = 0;
  all.min_area = 1;
  for (bool tileable : {false, true}) {
    all.tileable = tileable;
    const ParticleAnalysis a = texsynth::analyse_particles(s.view(), all);
    ASSERT_EQ(a.particles.size(), 1u);
    EXPECT_EQ(a.particles[0].area, W * H);
  }
  // Checkerboard and random labels: every pixel is background or in a particle, the same twice.
  ParticleAnalysisParams board = touching_params();
  board.labels.resize(size_t(W) * H);
  board.min_area = 1;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) board.labels[size_t(y) * W + x] = (x + y) % 2;
  EXPECT_NO_THROW(texsynth::analyse_particles(s.view(), board));
  texsynth::Rng rng(11);
  for (int32_t& l : board.labels) l = int32_t(rng.below(4));
  for (bool tileable : {false, true}) {
    board.tileable = tileable;
    const ParticleAnalysis a = texsynth::analyse_particles(s.view(), board);
    const ParticleAnalysis b = texsynth::analyse_particles(s.view(), board);
    EXPECT_EQ(a.components, b.components);
    for (size_t i = 0; i < a.components.size(); ++i)
      EXPECT_EQ(a.components[i] < 0, a.labels[i] == a.background) << i;
  }
  ParticleAnalysisParams bad = touching_params();
  for (double neck : {0.0, -0.5, 1.5, std::nan("")}) {
    bad.touching_neck = neck;
    EXPECT_THROW(texsynth::analyse_particles(s.view(), bad), std::invalid_argument) << neck;
  }
  bad = touching_params();
  for (double shading : {-0.1, 1.5, std::nan("")}) {
    bad.touching_shading = shading;
    EXPECT_THROW(texsynth::analyse_particles(s.view(), bad), std::invalid_argument) << shading;
  }
  bad = touching_params();
  for (double depth : {-1.0, 2000.0, std::nan("")}) {
    bad.touching_depth = depth;
    EXPECT_THROW(texsynth::analyse_particles(s.view(), bad), std::invalid_argument) << depth;
  }
}

TEST(ParticlesTouching, SameComponentsAtOneAndTwoThreads) {
  Scene s = flat(160, 120, 0.3f);
  texsynth::Rng rng(5);
  for (int k = 0; k < 40; ++k)
    paint_ellipse(s, 160 * rng.uniform(), 120 * rng.uniform(), 6 + 8 * rng.uniform(), 6 + 4 * rng.uniform(),
                  3 * rng.uniform(), 0.6f + 0.3f * float(rng.uniform()), true);
  add_noise(s, 0.05f, 9);
  ParticleAnalysisParams p = touching_params(4);
  p.blur_sigma = 1;
  p.tileable = true;
  ParticleAnalysis one, two;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    one = texsynth::analyse_particles(s.view(), p);
  }
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
    two = texsynth::analyse_particles(s.view(), p);
  }
  EXPECT_EQ(one.components, two.components);
  EXPECT_EQ(one.labels, two.labels);
  EXPECT_GT(one.particles.size(), 10u);
}

}  // namespace
