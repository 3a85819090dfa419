// SPDX-License-Identifier: GPL-3.0-or-later
// Preprocessing speed: textons + jump map on synthetic brick samples (256², 512², 1024²), with a
// per-stage breakdown, cache bytes per pixel, and a naive baseline measured in the same run
// (full-D Lloyd k-means with brute-force assignment + brute-force kNN, timed on a subsample and
// extrapolated). Run: build/cpp_tests/bench/bench_preprocess [--benchmark_filter=...]
#include <benchmark/benchmark.h>
#include <hnswlib/hnswlib.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
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
  state.counters["features_cpu"] = stats.features_cpu;
  state.counters["kmeans_cpu"] = stats.kmeans_cpu;
  state.counters["jumps_cpu"] = stats.jump_map_cpu;
  state.counters["total_cpu"] = stats.features_cpu + stats.kmeans_cpu + stats.tables_cpu + stats.jump_map_cpu;
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

// The texton-bucket jump search against exact brute force at 512²: time, recall and distance ratio
// for different candidate budgets (the default is JumpSearchParams::max_candidates).
struct JumpSetup {
  int size = 512;
  texsynth::Features features;
  texsynth::KMeansResult clusters;
  std::vector<int32_t> start, members;
  texsynth::CentreIndex index;
};
const JumpSetup& jump_setup() {
  static const JumpSetup setup = [] {
    JumpSetup s;
    const texsynth::Image image = texsynth_test::brick_texture(s.size, s.size);
    s.features = texsynth::compute_features(image, 11, 16, false, 0);
    texsynth::KMeansParams km;
    km.num_clusters = s.size;
    s.clusters = texsynth::kmeans(s.features, km);
    texsynth::build_buckets(s.clusters.labels, km.num_clusters, s.start, s.members);
    s.index = texsynth::build_centre_index(
        texsynth::centre_distance_table(s.clusters.centres, km.num_clusters, s.features.dims), km.num_clusters, 64);
    return s;
  }();
  return setup;
}

void BM_JumpSearch(benchmark::State& state) {
  const JumpSetup& s = jump_setup();
  texsynth::JumpSearchParams jp;
  jp.max_candidates = int(state.range(0));
  texsynth::JumpMap map;
  for (auto _ : state)
    map = texsynth::build_jump_map(s.features, s.size, s.size, s.clusters.labels, s.start, s.members, s.index, jp);
  double found = 0, exact = 0;
  int hits = 0, total = 0;
  for (int64_t p = 7; p < int64_t(s.size) * s.size; p += 877) {
    std::vector<int32_t> targets;
    std::vector<float> distances;
    texsynth::brute_force_jumps(s.features, s.size, s.size, p, jp, targets, distances);
    for (int i = 0; i < jp.k; ++i) {
      const int32_t t = map.targets[size_t(p) * jp.k + i];
      if (t >= 0) found += texsynth::squared_distance(s.features.row(p), s.features.row(t), s.features.dims);
      hits += std::count(targets.begin(), targets.end(), t) > 0;
      ++total;
    }
    for (float d : distances) exact += d;
  }
  state.counters["recall"] = double(hits) / total;
  state.counters["dist_vs_exact"] = found / exact;
}
BENCHMARK(BM_JumpSearch)->Arg(128)->Arg(256)->Arg(512)->Arg(768)->Arg(1536)->Unit(benchmark::kMillisecond)
    ->Iterations(1)->UseRealTime();

// The off-the-shelf alternative: an HNSW index (hnswlib, M = 16, ef = 64) over all 512² reduced features,
// built in parallel, queried for 48 neighbours per pixel and filtered by the exclusion rule.
void BM_JumpSearchHnsw(benchmark::State& state) {
  const JumpSetup& s = jump_setup();
  const int64_t n = int64_t(s.size) * s.size;
  texsynth::JumpSearchParams jp;
  std::vector<int32_t> found(size_t(n) * jp.k, -1);
  for (auto _ : state) {
    hnswlib::L2Space space(size_t(s.features.dims));
    hnswlib::HierarchicalNSW<float> index(&space, size_t(n), 16, 100, 7);
    index.addPoint(s.features.row(0), 0);
    tbb::parallel_for(tbb::blocked_range<int64_t>(1, n, 1024), [&](const tbb::blocked_range<int64_t>& r) {
      for (int64_t p = r.begin(); p < r.end(); ++p) index.addPoint(s.features.row(p), size_t(p));
    });
    index.setEf(64);
    tbb::parallel_for(tbb::blocked_range<int64_t>(0, n, 1024), [&](const tbb::blocked_range<int64_t>& r) {
      for (int64_t p = r.begin(); p < r.end(); ++p) {
        auto heap = index.searchKnn(s.features.row(p), 48);
        std::vector<std::pair<float, int32_t>> hits;
        while (!heap.empty()) {
          hits.emplace_back(heap.top().first, int32_t(heap.top().second));
          heap.pop();
        }
        std::sort(hits.begin(), hits.end());
        int stored = 0;
        for (const auto& [d, q] : hits) {
          if (stored == jp.k) break;
          if (!texsynth::within_exclusion(p, q, s.size, s.size, jp.neighbourhood, false))
            found[size_t(p) * jp.k + size_t(stored++)] = q;
        }
      }
    });
  }
  double got = 0, exact = 0;
  int hits = 0, total = 0;
  for (int64_t p = 7; p < n; p += 877) {
    std::vector<int32_t> targets;
    std::vector<float> distances;
    texsynth::brute_force_jumps(s.features, s.size, s.size, p, jp, targets, distances);
    for (int i = 0; i < jp.k; ++i) {
      const int32_t t = found[size_t(p) * jp.k + i];
      if (t >= 0) got += texsynth::squared_distance(s.features.row(p), s.features.row(t), s.features.dims);
      hits += std::count(targets.begin(), targets.end(), t) > 0;
      ++total;
    }
    for (float d : distances) exact += d;
  }
  state.counters["recall"] = double(hits) / total;
  state.counters["dist_vs_exact"] = got / exact;
}
BENCHMARK(BM_JumpSearchHnsw)->Unit(benchmark::kMillisecond)->Iterations(1)->UseRealTime();

// Exact brute-force kNN at 512² for a subsample of queries, extrapolated: the baseline the jump search replaces.
void BM_JumpSearchBruteForce(benchmark::State& state) {
  const JumpSetup& s = jump_setup();
  texsynth::JumpSearchParams jp;
  std::vector<int32_t> targets;
  std::vector<float> distances;
  const int queries = 64;
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    for (int q = 0; q < queries; ++q)
      texsynth::brute_force_jumps(s.features, s.size, s.size, int64_t(q) * 4099 % (int64_t(s.size) * s.size), jp,
                                  targets, distances);
    state.counters["all_pixels_s_extrap"] = seconds_since(start) * double(s.size) * s.size / queries;
  }
}
BENCHMARK(BM_JumpSearchBruteForce)->Unit(benchmark::kMillisecond)->Iterations(1)->UseRealTime();

// Clustering faithfulness of PCA: k-means on full-D vs reduced features, both judged by the
// within-cluster SSE in the full feature space (lower is better), at 128² (K = 128).
void BM_PcaFaithfulness(benchmark::State& state) {
  const int dims = int(state.range(0));
  const texsynth::Image image = texsynth_test::brick_texture(128, 128, 3);
  static const texsynth::Features full = texsynth::compute_features(image, 11, 0, false, 0);
  texsynth::KMeansParams km;
  km.num_clusters = 128;
  double sse = 0;
  for (auto _ : state) {
    const texsynth::Features reduced = dims > 0 ? texsynth::compute_features(image, 11, dims, false, 0) : full;
    const texsynth::KMeansResult r = texsynth::kmeans(reduced, km);
    sse = texsynth::within_cluster_sse(full, r.labels, km.num_clusters);
  }
  static double full_sse = 0;
  if (dims == 0) full_sse = sse;
  state.counters["full_space_sse"] = sse;
  if (full_sse > 0) state.counters["sse_vs_fullD"] = sse / full_sse;
}
BENCHMARK(BM_PcaFaithfulness)->Arg(0)->Arg(8)->Arg(16)->Arg(32)->Unit(benchmark::kMillisecond)->Iterations(1)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
