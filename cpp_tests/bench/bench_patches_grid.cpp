// SPDX-License-Identifier: GPL-3.0-or-later
// Grid-patch tracing (vector-field patches, issue 14) at the 1024² target's scale: ~1M surface samples
// on an 81,920-face noise-displaced icosphere of area ~4π, one grid step per sample spacing
// (h = sqrt(area / 1M)), patch centres on a jittered lattice at w/2 (patch sampling) and w/4
// (optimisation) for w = 32. A rotation field about a tilted axis (two singularities). Reports
// grid points/s, patches/s, invalid fraction and bytes per surface sample, at 1 and 2 threads, with
// sub-steps of half a grid step (the default) against a quarter (the first row, same run).
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <cmath>
#include <vector>

#include "../neighbourhood_fixtures.hpp"
#include "texsynth/common/rng.hpp"
#include "texsynth/patches/grid_patch.hpp"

namespace {

constexpr double kSamples = 1e6;
constexpr int32_t kPatch = 32;

struct Scene {
  ring_fixtures::TriMesh mesh;
  std::vector<float> dirs;
  texsynth::PatchField field, quarter_step;  // sub-steps of half and of a quarter grid step
  double h = 0, area = 0;
};

const Scene& scene() {
  static Scene s = [] {
    Scene sc;
    sc.mesh = ring_fixtures::icosphere(6, 1.0);
    for (int32_t v = 0; v < sc.mesh.num_vertices(); ++v) {
      float* p = &sc.mesh.positions[3 * size_t(v)];
      const double bump = 1 + 0.03 * std::sin(5 * p[0]) * std::sin(4 * p[1] + 1) * std::sin(3 * p[2] + 2);
      for (int k = 0; k < 3; ++k) p[k] = float(p[k] * bump);
      const texsynth::V3 t = texsynth::cross(texsynth::V3{0.3, 0.2, 1}, texsynth::V3{p[0], p[1], p[2]});
      sc.dirs.insert(sc.dirs.end(), {float(t.x), float(t.y), float(t.z)});
    }
    for (int32_t t = 0; t < sc.mesh.num_triangles(); ++t) {
      const auto a = sc.mesh.corner(t, 0), b = sc.mesh.corner(t, 1), c = sc.mesh.corner(t, 2);
      const texsynth::V3 e1{b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2{c[0] - a[0], c[1] - a[1], c[2] - a[2]};
      sc.area += 0.5 * texsynth::norm(texsynth::cross(e1, e2));
    }
    sc.h = std::sqrt(sc.area / kSamples);
    texsynth::PatchFieldInput in;
    in.mesh = sc.mesh.input();
    in.directions = sc.dirs.data();
    texsynth::PatchFieldParams p;
    p.spacing = sc.h;
    sc.field = texsynth::build_patch_field(in, p);
    p.substep = 0.25;
    sc.quarter_step = texsynth::build_patch_field(in, p);
    return sc;
  }();
  return s;
}

// Centres spaced `spacing` grid steps apart: as many as the area holds, at random faces (area-weighted).
std::vector<texsynth::FacePoint> centres(const Scene& sc, double spacing) {
  const int64_t count = int64_t(sc.area / (spacing * sc.h * spacing * sc.h));
  std::vector<double> cdf;
  double acc = 0;
  for (int32_t t = 0; t < sc.mesh.num_triangles(); ++t) {
    const auto a = sc.mesh.corner(t, 0), b = sc.mesh.corner(t, 1), c = sc.mesh.corner(t, 2);
    const texsynth::V3 e1{b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2{c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    cdf.push_back(acc += texsynth::norm(texsynth::cross(e1, e2)));
  }
  texsynth::Rng rng(5);
  std::vector<texsynth::FacePoint> out;
  for (int64_t i = 0; i < count; ++i) {
    const int32_t t = int32_t(std::lower_bound(cdf.begin(), cdf.end(), rng.uniform() * acc) - cdf.begin());
    float b1 = float(rng.uniform()), b2 = float(rng.uniform());
    if (b1 + b2 > 1) b1 = 1 - b1, b2 = 1 - b2;
    out.push_back({std::min(t, sc.mesh.num_triangles() - 1), b1, b2});
  }
  return out;
}

void BM_TraceGridPatches(benchmark::State& state) {
  const Scene& sc = scene();
  const double spacing = kPatch / double(state.range(0));  // w/2 or w/4
  const texsynth::PatchField& field = state.range(2) == 4 ? sc.quarter_step : sc.field;
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(state.range(1)));
  const std::vector<texsynth::FacePoint> c = centres(sc, spacing);
  texsynth::GridPatches g;
  for (auto _ : state) {
    g = texsynth::trace_grid_patches(field, c.data(), int32_t(c.size()), kPatch);
    benchmark::DoNotOptimize(g.points.data());
  }
  const double points = double(c.size()) * kPatch * kPatch;
  state.counters["patches"] = double(c.size());
  state.counters["grid_points/s"] = benchmark::Counter(points * double(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["invalid_%"] = 100.0 * double(g.invalid_points) / points;
  // FacePoint (12 B) + position (12 B) + cell flag per grid point, over the surface samples.
  state.counters["bytes/sample"] = points * (sizeof(texsynth::FacePoint) + 3 * sizeof(float) + 1) / kSamples;
}

}  // namespace

BENCHMARK(BM_TraceGridPatches)
    ->ArgNames({"w_over", "threads", "substeps"})
    ->Args({2, 2, 4})  // baseline: a quarter grid step
    ->Args({2, 1, 2})
    ->Args({2, 2, 2})
    ->Args({4, 2, 2})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1);

BENCHMARK_MAIN();
