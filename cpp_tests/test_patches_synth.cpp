// SPDX-License-Identifier: GPL-3.0-or-later
// Patch centres, sample location and patch synthesis on the surface (patches/coverage.hpp,
// patches/patch_synth.hpp), on a plane whose samples form a lattice one grid step apart.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "neighbourhood_fixtures.hpp"
#include "synthetic_texture.hpp"
#include "texsynth/common/errors.hpp"
#include "texsynth/common/rng.hpp"
#include "texsynth/patches/patch_synth.hpp"

namespace {

using texsynth::FacePoint;
using texsynth::V3;

// A unit plane (cells x cells grid of triangles) with a constant field along +y and
// res x res samples at the centres of a res² lattice: sample (x, y) at index y·res + x.
struct PlaneScene {
  ring_fixtures::TriMesh mesh;
  std::vector<float> dirs, positions, normals, bary;
  std::vector<int32_t> tri;
  int res = 0;
  double h = 0;
  texsynth::PatchField field;

  PlaneScene(int res_, int cells = 13) : res(res_), h(1.0 / res_) {
    mesh = ring_fixtures::plane(cells, cells, 1.0 / cells, 0.0);  // edges across the lattice, not along it
    for (int32_t v = 0; v < mesh.num_vertices(); ++v) dirs.insert(dirs.end(), {0.f, 1.f, 0.f});
    for (int y = 0; y < res; ++y)
      for (int x = 0; x < res; ++x) {
        const double px = (x + 0.5) * h, py = (y + 0.5) * h;
        const FacePoint f = locate(px, py);
        positions.insert(positions.end(), {float(px), float(py), 0.f});
        normals.insert(normals.end(), {0.f, 0.f, 1.f});
        tri.push_back(f.triangle);
        bary.insert(bary.end(), {f.b1, f.b2});
      }
    texsynth::PatchFieldInput in;
    in.mesh = mesh.input();
    in.directions = dirs.data();
    texsynth::PatchFieldParams p;
    p.spacing = h;
    field = texsynth::build_patch_field(in, p);
  }
  FacePoint locate(double x, double y) const {
    for (int32_t t = 0; t < mesh.num_triangles(); ++t) {
      auto p0 = mesh.corner(t, 0), p1 = mesh.corner(t, 1), p2 = mesh.corner(t, 2);
      const double d = (p1[0] - p0[0]) * (p2[1] - p0[1]) - (p2[0] - p0[0]) * (p1[1] - p0[1]);
      const double b1 = ((x - p0[0]) * (p2[1] - p0[1]) - (p2[0] - p0[0]) * (y - p0[1])) / d;
      const double b2 = ((p1[0] - p0[0]) * (y - p0[1]) - (x - p0[0]) * (p1[1] - p0[1])) / d;
      if (b1 >= -1e-9 && b2 >= -1e-9 && b1 + b2 <= 1 + 1e-9) return {t, float(std::max(b1, 0.0)), float(std::max(b2, 0.0))};
    }
    return {};
  }
  texsynth::PatchSamples samples() const {
    texsynth::PatchSamples s;
    s.positions = positions.data();
    s.normals = normals.data();
    s.triangle = tri.data();
    s.barycentric = bary.data();
    s.count = int32_t(tri.size());
    return s;
  }
};

struct Exemplar {
  int size;
  std::vector<float> pixels;
  texsynth::ExemplarIndex index;
  texsynth::ExemplarSample view() const { return {pixels.data(), size, size, 3}; }
};

// Value noise: every patch is distinct. Tileable noise wraps exactly (period = size).
Exemplar noise_exemplar(int size, int patch, bool tileable, uint64_t seed = 9) {
  Exemplar e{size, std::vector<float>(size_t(size) * size * 3), {}};
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x)
      for (int c = 0; c < 3; ++c) {
        float v = 0;
        if (tileable) {
          const double a = 2 * 3.14159265358979 * x / size, b = 2 * 3.14159265358979 * y / size;
          v = float(0.5 + 0.2 * std::sin(3 * a + c + std::cos(2 * b)) + 0.15 * std::sin(5 * b + 2 * c + std::sin(a)) +
                    0.1 * std::sin(7 * a + 4 * b + c));
        } else {
          v = 0.6f * texsynth_test::value_noise(float(x), float(y), 5.f, seed + c) +
              0.4f * texsynth_test::value_noise(float(x), float(y), 2.f, seed + 7 + c);
        }
        e.pixels[(size_t(y) * size + x) * 3 + c] = v;
      }
  texsynth::ExemplarParams p;
  p.patch_size = patch;
  p.tileable = tileable;
  p.seed = seed;
  e.index = texsynth::build_exemplar_index(e.view(), p);
  return e;
}

texsynth::SurfacePatchResult run(const PlaneScene& scene, const Exemplar& ex, texsynth::PatchMode mode,
                                 double tolerance = 1.2, uint64_t seed = 1) {
  texsynth::SurfacePatchParams p;
  p.synth.mode = mode;
  p.synth.tolerance = tolerance;
  p.synth.seed = seed;
  p.synth.iterations = 4;
  p.centre_spacing = mode == texsynth::PatchMode::kSampling ? 0.5 : 0.25;
  return texsynth::synthesize_patches_on_surface(scene.field, scene.samples(), ex.index, ex.view(), p);
}

TEST(PatchesCoverage, CentresAreAPoissonDiskOverTheSamplesAndDependOnTheSeed) {
  const PlaneScene scene(96);
  const double spacing = 8;  // steps
  const auto a = texsynth::choose_patch_centres(scene.field, scene.samples(), spacing, 1);
  const auto b = texsynth::choose_patch_centres(scene.field, scene.samples(), spacing, 1);
  const auto c = texsynth::choose_patch_centres(scene.field, scene.samples(), spacing, 2);
  ASSERT_GT(a.size(), 50u);
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(0, std::memcmp(a.data(), b.data(), a.size() * sizeof(FacePoint)));
  EXPECT_TRUE(a.size() != c.size() || std::memcmp(a.data(), c.data(), a.size() * sizeof(FacePoint)) != 0);
  std::vector<std::array<double, 3>> pts;
  for (const FacePoint& f : a) pts.push_back(scene.mesh.point(f.triangle, f.b1, f.b2));
  const double r = spacing * scene.h;
  for (size_t i = 0; i < pts.size(); ++i)
    for (size_t j = i + 1; j < pts.size(); ++j)
      EXPECT_GE(std::hypot(pts[i][0] - pts[j][0], pts[i][1] - pts[j][1]), r * (1 - 1e-6));
  // Nothing is far from a centre: no sample lies farther than 2r from all of them.
  double worst = 0;
  for (size_t s = 0; s < scene.tri.size(); ++s) {
    double best = 1e9;
    for (auto& p : pts) best = std::min(best, std::hypot(p[0] - scene.positions[3 * s], p[1] - scene.positions[3 * s + 1]));
    worst = std::max(worst, best);
  }
  EXPECT_LT(worst, 2 * r);
}

TEST(PatchesCoverage, SamplesAreLocatedAtTheirExactGridCoordinates) {
  const PlaneScene scene(64);
  const auto centres = texsynth::choose_patch_centres(scene.field, scene.samples(), 6, 3);
  const int n = 20, c = n / 2;
  const texsynth::GridPatches g = texsynth::trace_grid_patches(scene.field, centres.data(), int32_t(centres.size()), n);
  const texsynth::PatchCoverage cov = texsynth::locate_samples(scene.field, g, scene.samples());
  ASSERT_EQ(cov.sample_start.size(), scene.tri.size() + 1);
  int64_t entries = 0;
  double worst = 0;
  for (int32_t p = 0; p < g.count; ++p) {
    const V3 pc = texsynth::v3(&g.positions[3 * ((size_t(p) * n + c) * n + c)]);
    for (int64_t e = cov.patch_start[p]; e < cov.patch_start[size_t(p) + 1]; ++e) {
      const int32_t s = cov.patch_sample[e];
      const double u = c + (scene.positions[3 * size_t(s)] - pc.x) / scene.h;
      const double v = c + (scene.positions[3 * size_t(s) + 1] - pc.y) / scene.h;
      worst = std::max({worst, std::fabs(cov.patch_uv[2 * e] - u), std::fabs(cov.patch_uv[2 * e + 1] - v)});
      ++entries;
    }
  }
  EXPECT_LT(worst, 1e-3);
  EXPECT_EQ(entries, int64_t(cov.sample_patch.size()));
  // Every sample inside the plane (away from the border the grids cannot cross) is located.
  for (int y = 2; y < 62; ++y)
    for (int x = 2; x < 62; ++x) {
      const size_t s = size_t(y) * 64 + x;
      EXPECT_GT(cov.sample_start[s + 1], cov.sample_start[s]) << "sample " << x << "," << y;
    }
}

TEST(PatchesCoverage, PatchesAddedLaterGiveTheSameGridsAndCoverageAsAllAtOnce) {
  // The surface pass traces and locates its extra round of patches alone, then appends and merges.
  const PlaneScene scene(64);
  const auto first = texsynth::choose_patch_centres(scene.field, scene.samples(), 6, 3);
  const auto more = texsynth::choose_patch_centres(scene.field, scene.samples(), 9, 4);
  ASSERT_GT(first.size(), 10u);
  ASSERT_GT(more.size(), 10u);
  std::vector<texsynth::FacePoint> all = first;
  all.insert(all.end(), more.begin(), more.end());
  const int n = 20;
  const auto whole = texsynth::trace_grid_patches(scene.field, all.data(), int32_t(all.size()), n);
  const auto whole_cov = texsynth::locate_samples(scene.field, whole, scene.samples());
  auto parts = texsynth::trace_grid_patches(scene.field, first.data(), int32_t(first.size()), n);
  const auto first_cov = texsynth::locate_samples(scene.field, parts, scene.samples());
  texsynth::append_grid_patches(parts, texsynth::trace_grid_patches(scene.field, more.data(), int32_t(more.size()), n));
  const auto more_cov = texsynth::locate_samples(scene.field, parts, scene.samples(), nullptr, int32_t(first.size()));
  EXPECT_EQ(more_cov.patch_start[first.size()], 0);  // the first patches were not located again
  const auto merged = texsynth::merge_coverage(first_cov, more_cov);
  EXPECT_EQ(parts.count, whole.count);
  EXPECT_EQ(parts.positions, whole.positions);
  EXPECT_EQ(parts.cell_valid, whole.cell_valid);
  EXPECT_EQ(parts.invalid_points, whole.invalid_points);
  EXPECT_EQ(merged.sample_start, whole_cov.sample_start);
  EXPECT_EQ(merged.sample_patch, whole_cov.sample_patch);
  EXPECT_EQ(merged.sample_uv, whole_cov.sample_uv);
  EXPECT_EQ(merged.patch_start, whole_cov.patch_start);
  EXPECT_EQ(merged.patch_sample, whole_cov.patch_sample);
  EXPECT_EQ(merged.patch_uv, whole_cov.patch_uv);
  EXPECT_EQ(merged.uncovered, whole_cov.uncovered);
  GTEST_ASSERT_GT(merged.sample_patch.size(), first_cov.sample_patch.size());
  EXPECT_THROW(texsynth::append_grid_patches(parts, texsynth::trace_grid_patches(scene.field, more.data(), 1, n + 2)),
               std::invalid_argument);
}

TEST(PatchesSynth, SamplingContinuesATileableExemplarWithoutASeam) {
  // Every patch has an exact continuation (distance 0) in a tileable exemplar: with tolerance 1 the
  // whole plane becomes one coherent copy, so neighbouring samples read neighbouring exemplar pixels.
  // Any error in location, alignment, matching or pasting breaks this somewhere.
  const PlaneScene scene(80);
  const Exemplar ex = noise_exemplar(48, 16, true);
  const texsynth::SurfacePatchResult r = run(scene, ex, texsynth::PatchMode::kSampling, 1.0);
  EXPECT_EQ(r.synth.stats.random_patches, 1);  // only the first
  const auto& src = r.synth.source;
  int64_t pairs = 0, continuous = 0;
  auto wrapped = [](double d) { return d - 48 * std::round(d / 48); };
  for (int y = 0; y < 80; ++y)
    for (int x = 0; x + 1 < 80; ++x) {
      const size_t a = size_t(y) * 80 + x, b = a + 1;
      ++pairs;
      continuous += std::fabs(wrapped(src[2 * b] - src[2 * a] - 1)) < 0.05 && std::fabs(wrapped(src[2 * b + 1] - src[2 * a + 1])) < 0.05;
    }
  EXPECT_GE(double(continuous) / double(pairs), 0.995) << continuous << " of " << pairs;
}

TEST(PatchesSynth, SameBytesForOneAndTwoThreadsInBothModes) {
  const PlaneScene scene(64);
  const Exemplar ex = noise_exemplar(56, 16, false);
  for (auto mode : {texsynth::PatchMode::kSampling, texsynth::PatchMode::kOptimisation}) {
    auto once = [&](int threads) {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
      return run(scene, ex, mode);
    };
    const auto a = once(1), b = once(2);
    ASSERT_EQ(a.synth.colour.size(), b.synth.colour.size());
    EXPECT_EQ(0, std::memcmp(a.synth.colour.data(), b.synth.colour.data(), a.synth.colour.size() * sizeof(float)));
    EXPECT_EQ(a.synth.origin, b.synth.origin);
    const auto c = run(scene, ex, mode, 1.2, 99);
    EXPECT_NE(a.synth.colour, c.synth.colour) << "another seed gives another texture";
  }
}

TEST(PatchesSynth, OptimisationLowersTheEnergyAndEverySampleIsColoured) {
  const PlaneScene scene(64);
  const Exemplar ex = noise_exemplar(56, 16, false);
  const auto r = run(scene, ex, texsynth::PatchMode::kOptimisation);
  ASSERT_GE(r.synth.stats.energy.size(), 2u);
  EXPECT_LT(r.synth.stats.energy.back(), r.synth.stats.energy.front());
  for (size_t s = 0; s < scene.tri.size(); ++s) EXPECT_GE(r.synth.source[2 * s], 0.f) << "sample " << s;
  for (float v : r.synth.colour) ASSERT_TRUE(std::isfinite(v));
}

TEST(PatchesSynth, AnExactCopyGivenAsTheStartIsKeptByTheOptimisation) {
  // The finer levels of a multi-resolution optimisation start from given exemplar coordinates. A start
  // that copies the exemplar pixel for pixel matches every patch at distance 0: it must come back as it
  // went in, where the default start (patch sampling) gives another arrangement.
  const PlaneScene scene(32);
  const Exemplar ex = noise_exemplar(40, 16, false);
  std::vector<float> start(scene.tri.size() * 2);
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x) start[2 * size_t(y * 32 + x)] = x + 4.5f, start[2 * size_t(y * 32 + x) + 1] = y + 4.5f;
  texsynth::SurfacePatchParams p;
  p.synth.mode = texsynth::PatchMode::kOptimisation;
  p.synth.iterations = 3;
  p.levels = 1;
  p.centre_spacing = 0.3;
  p.synth.initial_source = start.data();
  const auto kept = texsynth::synthesize_patches_on_surface(scene.field, scene.samples(), ex.index, ex.view(), p);
  p.synth.initial_source = nullptr;
  const auto sampled = texsynth::synthesize_patches_on_surface(scene.field, scene.samples(), ex.index, ex.view(), p);
  int64_t same = 0, same_sampled = 0;
  for (size_t s = 0; s < scene.tri.size(); ++s) {
    same += std::fabs(kept.synth.source[2 * s] - start[2 * s]) < 1e-4 && std::fabs(kept.synth.source[2 * s + 1] - start[2 * s + 1]) < 1e-4;
    same_sampled += std::fabs(sampled.synth.source[2 * s] - start[2 * s]) < 1e-4 &&
                    std::fabs(sampled.synth.source[2 * s + 1] - start[2 * s + 1]) < 1e-4;
  }
  EXPECT_GT(same, int64_t(scene.tri.size() * 95 / 100));
  EXPECT_LT(same_sampled, int64_t(scene.tri.size() / 2));
}

TEST(PatchesSynth, MultiResolutionRunsTheLevelsTheSampleAllows) {
  const PlaneScene scene(48);
  texsynth::SurfacePatchParams p;
  p.synth.mode = texsynth::PatchMode::kOptimisation;
  p.synth.iterations = 2;
  p.centre_spacing = 0.3;
  p.levels = 3;
  // 48 px: levels at 48 and 24; 12 would be below the smallest exemplar a patch fits (16).
  const Exemplar ex = noise_exemplar(48, 16, false);
  const auto r = texsynth::synthesize_patches_on_surface(scene.field, scene.samples(), ex.index, ex.view(), p);
  EXPECT_EQ(r.levels, 2);
  EXPECT_GT(r.seconds_coarse, 0.0);
  for (size_t s = 0; s < scene.tri.size(); ++s) ASSERT_GE(r.synth.source[2 * s], 0.f) << "sample " << s;
  p.levels = 1;
  EXPECT_EQ(texsynth::synthesize_patches_on_surface(scene.field, scene.samples(), ex.index, ex.view(), p).levels, 1);
  p.synth.mode = texsynth::PatchMode::kSampling;  // sampling has one level whatever is asked
  p.levels = 3;
  EXPECT_EQ(texsynth::synthesize_patches_on_surface(scene.field, scene.samples(), ex.index, ex.view(), p).levels, 1);
}

TEST(PatchesSynth, LevelPlanIsWhatTheSynthesisRuns) {
  using texsynth::PatchMode;
  // 48 px, 16 px patches: 48 then 24 (12 cannot hold the smallest exemplar), each fitted.
  auto plan = texsynth::patch_level_sizes(48, 48, 16, false, PatchMode::kOptimisation, 3);
  ASSERT_EQ(plan.size(), 2u);
  EXPECT_EQ(plan[1].width, 24);
  EXPECT_EQ(plan[1].patch_size, texsynth::fit_patch_size(24, 24, 16));
  EXPECT_EQ(plan[1].patch_size, 16);  // 24 px sides still hold 16 px patches with 3 px to spare
  // 36 px: 36 then 18, where 16 px patches lack the 3 px spare and get 8 (the largest multiple of 4 up to 9).
  plan = texsynth::patch_level_sizes(36, 36, 16, false, PatchMode::kOptimisation, 3);
  ASSERT_EQ(plan.size(), 2u);
  EXPECT_EQ(plan[1].patch_size, 8);
  EXPECT_EQ(texsynth::patch_level_sizes(48, 48, 16, false, PatchMode::kSampling, 3).size(), 1u);
  plan = texsynth::patch_level_sizes(512, 256, 32, false, PatchMode::kOptimisation, 3);
  ASSERT_EQ(plan.size(), 3u);
  EXPECT_EQ(plan[2].width, 128);
  EXPECT_EQ(plan[2].height, 64);
  EXPECT_EQ(plan[2].patch_size, 32);
  EXPECT_THROW(texsynth::patch_level_sizes(48, 48, 16, false, PatchMode::kOptimisation, 0), std::invalid_argument);
  EXPECT_THROW(texsynth::patch_level_sizes(48, 48, 16, false, PatchMode::kOptimisation,
                                           texsynth::kMaxPatchLevels + 1),
               std::invalid_argument);
  // The synthesis runs exactly the plan's levels.
  const PlaneScene scene(48);
  texsynth::SurfacePatchParams p;
  p.synth.mode = PatchMode::kOptimisation;
  p.synth.iterations = 1;
  p.centre_spacing = 0.3;
  p.levels = 3;
  const Exemplar ex = noise_exemplar(48, 16, false);
  EXPECT_EQ(size_t(texsynth::synthesize_patches_on_surface(scene.field, scene.samples(), ex.index, ex.view(), p).levels),
            texsynth::patch_level_sizes(48, 48, ex.index.patch_size, false, PatchMode::kOptimisation, 3).size());
}

TEST(PatchesSynth, BadParametersAreRefusedClearly) {
  const PlaneScene scene(32);
  const Exemplar ex = noise_exemplar(40, 16, false);
  auto expect_refused = [&](auto&& mutate, const char* fragment) {
    texsynth::SurfacePatchParams p;
    mutate(p);
    try {
      texsynth::synthesize_patches_on_surface(scene.field, scene.samples(), ex.index, ex.view(), p);
      ADD_FAILURE() << "accepted; expected '" << fragment << "'";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
  };
  expect_refused([](auto& p) { p.synth.tolerance = 0.5; }, "tolerance");
  expect_refused([](auto& p) { p.synth.candidates = 0; }, "candidates");
  expect_refused([](auto& p) { p.synth.iterations = 0; }, "iterations");
  expect_refused([](auto& p) { p.synth.robust_exponent = 3; }, "robust_exponent");
  expect_refused([](auto& p) { p.centre_spacing = 0; }, "centre_spacing");
  expect_refused([](auto& p) { p.synth.boundary_width = 0; }, "boundary width");
  expect_refused([](auto& p) { p.synth.boundary_width = 9; }, "boundary width");  // patch 16: at most 8
  expect_refused([](auto& p) { p.levels = 0; }, "levels");
  expect_refused([](auto& p) { p.levels = texsynth::kMaxPatchLevels + 1; }, "levels");
  // A sample other than the analysed one.
  std::vector<float> other(size_t(40) * 40 * 4, 0.5f);
  texsynth::SurfacePatchParams p;
  EXPECT_THROW(texsynth::synthesize_patches_on_surface(scene.field, scene.samples(), ex.index, {other.data(), 40, 40, 4}, p),
               std::invalid_argument);
  // Grids traced at another size than the exemplar's patches need.
  const auto centres = texsynth::choose_patch_centres(scene.field, scene.samples(), 8, 1);
  const auto g = texsynth::trace_grid_patches(scene.field, centres.data(), int32_t(centres.size()), 16);
  const auto cov = texsynth::locate_samples(scene.field, g, scene.samples());
  EXPECT_THROW(texsynth::synthesize_patches(g, cov, int32_t(scene.tri.size()), ex.index, ex.view(), {}), std::invalid_argument);
}

TEST(PatchesSynth, CancelStopsTheSynthesis) {
  const PlaneScene scene(32);
  const Exemplar ex = noise_exemplar(40, 16, false);
  std::atomic<bool> cancel{true};
  texsynth::SurfacePatchParams p;
  p.synth.cancel = &cancel;
  EXPECT_THROW(texsynth::synthesize_patches_on_surface(scene.field, scene.samples(), ex.index, ex.view(), p),
               texsynth::Cancelled);
}

}  // namespace
