// SPDX-License-Identifier: GPL-3.0-or-later
// Decal geometry at the scale (issue 15: writing the decal geometry of 20k particles into
// Blender <= 1 s; this is the native part): 20,000 particles on a 101,760-face bumpy UV sphere (the
// placement bench's mesh), rectangles of about one particle spacing (the sphere's area / 20,000, so
// the decals tile it about once), random axes, at 1 and 2 threads. Reports the output sizes.
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <cmath>
#include <vector>

#include "bumpy_sphere.hpp"
#include "texsynth/common/rng.hpp"
#include "texsynth/particles/decals.hpp"

namespace {

constexpr int kParticles = 20000;

struct Scene {
  ring_fixtures::TriMesh mesh;
  texsynth::SurfaceWalkMesh s;
  std::vector<texsynth::DecalParticle> particles;
};

const Scene& scene(double size_factor) {
  static Scene sc = [] {
    Scene s;
    s.mesh = bench_fixtures::bumpy_sphere();
    s.s = texsynth::build_surface_walk_mesh(s.mesh.input());
    return s;
  }();
  // Uniform over the triangles' index (areas vary at the poles; the mix of sizes is what matters).
  const double spacing = std::sqrt(4 * 3.14159265358979 / kParticles) * size_factor;
  sc.particles.clear();
  texsynth::Rng rng(12);
  for (int i = 0; i < kParticles; ++i) {
    texsynth::DecalParticle p;
    const int32_t t = int32_t(rng.below(uint32_t(sc.mesh.num_triangles())));
    double b1 = rng.uniform(), b2 = rng.uniform();
    if (b1 + b2 > 1) b1 = 1 - b1, b2 = 1 - b2;
    p.anchor = {t, b1, b2};
    p.axis = {rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5};
    const double hu = 0.5 * spacing * (0.7 + 0.6 * rng.uniform()), hv = 0.5 * spacing * (0.7 + 0.6 * rng.uniform());
    p.rect = {-hu, -hv, hu, hv};
    p.uv_rect = {0, 0, 0.0625, 0.0625};
    sc.particles.push_back(p);
  }
  return sc;
}

void BM_DecalMesh(benchmark::State& state) {
  const Scene& sc = scene(double(state.range(1)) / 10);
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(state.range(0)));
  texsynth::DecalOptions o;
  o.offset = 1e-4;
  texsynth::DecalMesh d;
  for (auto _ : state) {
    d = texsynth::build_decal_mesh(sc.s, sc.particles.data(), kParticles, o);
    benchmark::DoNotOptimize(d.positions.data());
  }
  const double bytes = double(d.positions.size() * 4 + d.loop_starts.size() * 12 + d.corner_verts.size() * 12);
  state.counters["triangles"] = sc.mesh.num_triangles();
  state.counters["polygons"] = double(d.loop_starts.size());
  state.counters["vertices"] = double(d.positions.size() / 3);
  state.counters["corners"] = double(d.corner_verts.size());
  state.counters["poly/particle"] = double(d.loop_starts.size()) / kParticles;
  state.counters["MB"] = bytes / 1e6;
  state.counters["curved"] = double(d.stats.curved);
  state.counters["coverage"] = d.stats.mean_coverage;
}

}  // namespace

// Args: threads, rectangle size in tenths of the particle spacing (10 = one spacing, 30 = three).
BENCHMARK(BM_DecalMesh)
    ->ArgNames({"threads", "size_x10"})
    ->Args({1, 10})
    ->Args({2, 10})
    ->Args({1, 30})
    ->Args({2, 30})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

BENCHMARK_MAIN();
