// SPDX-License-Identifier: GPL-3.0-or-later
// Texture-particle analysis (particles/analysis.hpp) on a synthetic 512² pebble sample: noisy ground,
// ~300 ellipses of two colours, random sizes (radii 6..18 px) and orientations, >= 3 px apart.
//
// BM_ParticleAnalysis/threads: seconds per stage at 1 and 2 threads (issue 15 goal: <= 2 s at 512²).
// BM_NeighbourSearch/size/literal: the co-occurrence neighbour search over every particle of a size²
//   pebble sample, by one chessboard distance transform (0) vs the paper's step-by-step 3x3 dilation (1).
// BM_RimsCost/size/noise: the components stage with and without rims joining their element, same run.
// Run: build/cpp_tests/bench/bench_particles [--benchmark_filter=...]
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <vector>

#include "texsynth/common/rng.hpp"
#include "texsynth/particles/analysis.hpp"

namespace {

using Clock = std::chrono::steady_clock;

struct Sample {
  int size = 0;
  std::vector<float> pixels;
  texsynth::ParticleSample view() const { return {pixels.data(), size, size, 3}; }
};

Sample pebbles(int size, uint64_t seed = 7) {
  Sample s{size, std::vector<float>(size_t(size) * size * 3)};
  texsynth::Rng rng(seed);
  const float ground[3] = {0.45f, 0.4f, 0.33f}, stone[2][3] = {{0.75f, 0.72f, 0.68f}, {0.2f, 0.18f, 0.2f}};
  std::vector<int8_t> cls(size_t(size) * size, -1);
  const int tries = size * size / 300;
  for (int t = 0; t < tries; ++t) {
    const double cx = rng.uniform() * size, cy = rng.uniform() * size;
    const double a = 6 + 12 * rng.uniform(), b = a * (0.5 + 0.5 * rng.uniform()), th = 3.14159265 * rng.uniform();
    const int8_t k = int8_t(rng.below(2));
    const double c = std::cos(th), sn = std::sin(th);
    auto inside = [&](int x, int y, double grow) {
      const double dx = x + 0.5 - cx, dy = y + 0.5 - cy, u = (dx * c + dy * sn) / (a + grow), v = (-dx * sn + dy * c) / (b + grow);
      return u * u + v * v <= 1;
    };
    const int r = int(a) + 5;
    bool free = true;
    for (int y = std::max(0, int(cy) - r); y < std::min(size, int(cy) + r) && free; ++y)
      for (int x = std::max(0, int(cx) - r); x < std::min(size, int(cx) + r) && free; ++x)
        free = !(inside(x, y, 3) && cls[size_t(y) * size + x] >= 0);
    if (!free) continue;
    for (int y = std::max(0, int(cy) - r); y < std::min(size, int(cy) + r); ++y)
      for (int x = std::max(0, int(cx) - r); x < std::min(size, int(cx) + r); ++x)
        if (inside(x, y, 0)) cls[size_t(y) * size + x] = k;
  }
  for (size_t i = 0; i < cls.size(); ++i)
    for (int ch = 0; ch < 3; ++ch)
      s.pixels[i * 3 + ch] = (cls[i] < 0 ? ground[ch] : stone[cls[i]][ch]) + float(0.06 * (rng.uniform() - 0.5));
  return s;
}

void BM_ParticleAnalysis(benchmark::State& state) {
  static const Sample s = pebbles(512);
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(state.range(0)));
  texsynth::ParticleAnalysisParams p;
  p.classes = 3;
  texsynth::ParticleAnalysis a;
  for (auto _ : state) a = texsynth::analyse_particles(s.view(), p);
  const auto& t = a.stats;
  int64_t entries = int64_t(a.cooc.size()), complete = 0;
  for (const auto& part : a.particles) complete += part.complete;
  state.counters["particles"] = double(a.particles.size());
  state.counters["total_s"] = t.seconds_total;
  std::printf("analysis 512x512 k=3, %d thread(s): total %.3f s (blur %.3f, k-means %.3f, components %.3f, geometry "
              "%.3f, co-occurrence %.3f, background %.3f); %zu particles (%lld complete), %lld entries, %d merged\n",
              int(state.range(0)), t.seconds_total, t.seconds_blur, t.seconds_kmeans, t.seconds_components,
              t.seconds_geometry, t.seconds_cooccurrence, t.seconds_background, a.particles.size(),
              (long long)complete, (long long)entries, a.merged_components());
}
BENCHMARK(BM_ParticleAnalysis)->Arg(1)->Arg(2)->Unit(benchmark::kSecond)->Iterations(3)->UseRealTime();

// Rims' cost (conventions, "Rims"): the components stage with join_rims on and off in the same run, on the
// 512² pebbles and on uniform noise (a thin component everywhere: the worst case), best of 3 each.
void BM_RimsCost(benchmark::State& state) {
  const int size = int(state.range(0));
  const bool noise = state.range(1) != 0;
  Sample s = pebbles(size);
  if (noise) {
    texsynth::Rng rng(3);
    for (float& v : s.pixels) v = float(rng.uniform());
  }
  double seconds[2] = {1e9, 1e9};
  size_t particles[2] = {0, 0};
  for (auto _ : state)
    for (int rims = 0; rims < 2; ++rims) {
      texsynth::ParticleAnalysisParams p;
      p.classes = 4;
      p.join_rims = rims == 1;
      const texsynth::ParticleAnalysis a = texsynth::analyse_particles(s.view(), p);
      seconds[rims] = std::min(seconds[rims], a.stats.seconds_components);
      particles[rims] = a.particles.size();
    }
  std::printf("rims, %s %dx%d, k=4: components stage %.3f s without, %.3f s with (%zu -> %zu particles)\n",
              noise ? "noise" : "pebbles", size, size, seconds[0], seconds[1], particles[0], particles[1]);
}
BENCHMARK(BM_RimsCost)
    ->Args({512, 0})
    ->Args({2048, 1})
    ->Unit(benchmark::kSecond)
    ->Iterations(3)
    ->UseRealTime();

void BM_NeighbourSearch(benchmark::State& state) {
  const Sample s = pebbles(int(state.range(0)));
  const bool literal = state.range(1) != 0;
  texsynth::ParticleAnalysisParams p;
  p.classes = 3;
  const texsynth::ParticleAnalysis a = texsynth::analyse_particles(s.view(), p);
  size_t hits = 0;
  double seconds = 0;
  for (auto _ : state) {
    const auto t0 = Clock::now();
    hits = 0;
    for (int32_t id = 0; id < int32_t(a.particles.size()); ++id)
      hits += texsynth::particle_neighbours(a, id, literal).size();
    seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  }
  state.counters["hits"] = double(hits);
  std::printf("neighbour search %dx%d, %s: %.4f s for %zu particles (%zu hits), 1 thread\n", int(state.range(0)),
              int(state.range(0)), literal ? "literal 3x3 dilation" : "chessboard distance transform", seconds,
              a.particles.size(), hits);
}
BENCHMARK(BM_NeighbourSearch)
    ->ArgsProduct({{128, 512}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
