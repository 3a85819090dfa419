// SPDX-License-Identifier: GPL-3.0-or-later
// Particle placement at the scale (issue 15: 20k particles on a 100k-face mesh <= 1 s on 2
// cores; re-synthesis of one class <= 0.5 s): jittered discs (one class) on a 102,400-face torus with
// its ring field, ~20,000 particles, and a two-class sample (discs + squares) re-synthesising one class,
// at 1 and 2 threads. Reports particles, walks per particle and particles/s.
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <vector>

#include "../placement_fixtures.hpp"
#include "texsynth/particles/placement.hpp"

namespace {

using namespace placement_fixtures;

struct Scene {
  ring_fixtures::TriMesh mesh;
  texsynth::SurfaceWalkMesh walk;
  texsynth::ParticleAnalysis discs, mixed;
  std::vector<float> field;
};

const Scene& scene() {
  static Scene sc = [] {
    Scene s;
    s.mesh = torus(320, 160, 1.0, 0.4);  // 102,400 triangles, area 4 pi^2 R r = 15.8
    s.walk = texsynth::build_surface_walk_mesh(s.mesh.input());
    s.discs = analyse(jittered_discs());
    LabelSample two = jittered_discs(256, 4, 2);
    for (int j = 0; j < 4; ++j)
      for (int i = 0; i < 4; ++i) two.fill(8 + 64 * i, 8 + 64 * j, 14, 14, 1);
    s.mixed = analyse(two);
    s.field = ring_field(s.mesh);
    return s;
  }();
  return sc;
}

// 32 px disc spacing at 0.0008 world units per pixel: ~20,000 discs on the torus.
constexpr double kPixel = 0.0008;

void run(benchmark::State& state, const texsynth::ParticleAnalysis& a, std::vector<int32_t> output) {
  const Scene& sc = scene();
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(state.range(0)));
  texsynth::PlacementParams p;
  p.directions = sc.field;
  p.sample_world_width = kPixel * a.width;
  p.output_classes = std::move(output);  // re-synthesizing one class: those before it are placed too
  texsynth::PlacedParticles r;
  for (auto _ : state) {
    r = texsynth::place_particles(a, sc.walk, p);
    benchmark::DoNotOptimize(r.position.data());
  }
  int64_t reseeded = 0;
  for (const auto& c : r.stats.classes) reseeded += c.reseeded;
  state.counters["triangles"] = sc.mesh.num_triangles();
  state.counters["particles"] = double(r.size());
  state.counters["walks/particle"] = double(r.stats.walks) / double(r.size());
  state.counters["reseeded"] = double(reseeded);
  state.counters["particles/s"] =
      benchmark::Counter(double(r.size()) * double(state.iterations()), benchmark::Counter::kIsRate);
}

void BM_PlaceDiscsOnTorus(benchmark::State& state) { run(state, scene().discs, {}); }
void BM_ResynthesiseOneClass(benchmark::State& state) { run(state, scene().mixed, {2}); }

}  // namespace

BENCHMARK(BM_PlaceDiscsOnTorus)->ArgNames({"threads"})->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_ResynthesiseOneClass)->ArgNames({"threads"})->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

BENCHMARK_MAIN();
