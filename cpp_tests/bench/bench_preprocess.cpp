// SPDX-License-Identifier: GPL-3.0-or-later
// Preprocessing speed: textons + jump map on synthetic brick samples (256², 512², 1024²), with a
// per-stage breakdown, cache bytes per pixel, and a naive baseline measured in the same run
// (full-D Lloyd k-means with brute-force assignment + brute-force kNN, timed on a subsample and
// extrapolated). Run: build/cpp_tests/bench/bench_preprocess [--benchmark_filter=...]
#include <benchmark/benchmark.h>

#include <chrono>
#include <cstdio>
#include <filesystem>

#include "../synthetic_texture.hpp"
#include "texsynth/preprocess/cache.hpp"
#include "texsynth/preprocess/features.hpp"
#include "texsynth/preprocess/jump_map.hpp"
#include "texsynth/preprocess/kmeans.hpp"
#include "texsynth/preprocess/preprocess.hpp"

namespace {

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

void BM_Preprocess(benchmark::State& state) {
  const int size = int(state.range(0));
  const texsynth::Image image = texsynth_test::brick_texture(size, size);
  texsynth::PreprocessParams params;
  texsynth::PreprocessStats stats;
  texsynth::Preprocessed result;
  for (auto _ : state) result = texsynth::preprocess(image, params, nullptr, &stats);
  const auto path = std::filesystem::temp_directory_path() / "texsynth_bench.tscache";
  texsynth::save_preprocessed(result, path.string());
  state.counters["K"] = result.num_textons;
  state.counters["features_s"] = stats.features_seconds;
  state.counters["kmeans_s"] = stats.kmeans_seconds;
  state.counters["tables_s"] = stats.tables_seconds;
  state.counters["jumps_s"] = stats.jump_map_seconds;
  state.counters["km_iters"] = stats.kmeans_full_iterations;
  state.counters["cache_B_per_px"] = double(std::filesystem::file_size(path)) / double(size * size);
  std::filesystem::remove(path);
}
BENCHMARK(BM_Preprocess)->Arg(256)->Arg(512)->Arg(1024)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

// Naive: full-D features, 20 Lloyd iterations with brute-force assignment, brute-force kNN jump search.
// Timed on a subsample of points/queries and extrapolated to the whole sample.
void BM_NaiveBaseline(benchmark::State& state) {
  const int size = int(state.range(0));
  const texsynth::Image image = texsynth_test::brick_texture(size, size);
  const int64_t n = int64_t(size) * size;
  const int k = int(std::lround(std::sqrt(double(n))));
  double extrapolated = 0;
  for (auto _ : state) {
    auto start = std::chrono::steady_clock::now();
    const texsynth::Features full = texsynth::compute_features(image, 11, 0, false, 0);
    const double features_s = seconds_since(start);
    // One brute-force assignment of 4096 points to K full-D centres.
    std::vector<float> centres(full.values.begin(), full.values.begin() + size_t(k) * full.dims);
    texsynth::Features probe;
    probe.count = 4096;
    probe.dims = full.dims;
    probe.values.assign(full.values.begin(), full.values.begin() + size_t(probe.count) * full.dims);
    start = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(texsynth::assign_brute_force(probe, centres, k));
    const double kmeans_s = seconds_since(start) * double(n) / probe.count * 20;
    // Brute-force kNN for 16 queries over all pixels.
    texsynth::JumpSearchParams jp;
    std::vector<int32_t> targets;
    std::vector<float> distances;
    start = std::chrono::steady_clock::now();
    for (int q = 0; q < 16; ++q) texsynth::brute_force_jumps(full, size, size, int64_t(q) * 997 % n, jp, targets, distances);
    const double knn_s = seconds_since(start) * double(n) / 16;
    extrapolated = features_s + kmeans_s + knn_s;
    state.counters["kmeans_s_extrap"] = kmeans_s;
    state.counters["knn_s_extrap"] = knn_s;
  }
  state.counters["total_s_extrap"] = extrapolated;
}
BENCHMARK(BM_NaiveBaseline)->Arg(256)->Arg(512)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
