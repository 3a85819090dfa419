// SPDX-License-Identifier: GPL-3.0-or-later
// Preprocessing speed: textons + jump map on synthetic brick samples (256², 512², 1024²), with a
// per-stage breakdown, cache bytes per pixel, and a naive baseline measured in the same run
// (full-D Lloyd k-means with brute-force assignment + brute-force kNN, timed on a subsample and
// extrapolated). Run: build/cpp_tests/bench/bench_preprocess [--benchmark_filter=...]
#include <benchmark/benchmark.h>
#include <sys/resource.h>
#include <hnswlib/hnswlib.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <filesystem>
#include <thread>

#include "../synthetic_texture.hpp"
#include "texsynth/common/errors.hpp"
#include "texsynth/image_files/image_files.hpp"
#include "texsynth/preprocess/cache.hpp"
#include "texsynth/preprocess/features.hpp"
#include "texsynth/preprocess/jump_map.hpp"
#include "texsynth/preprocess/kmeans.hpp"
#include "texsynth/preprocess/preprocess.hpp"

namespace {

double peak_rss_mb() {
  struct rusage usage {};
  getrusage(RUSAGE_SELF, &usage);
  return double(usage.ru_maxrss) / 1024.0;
}

// Where the time went: wall and CPU seconds per stage (CPU = all threads).
void stage_counters(benchmark::State& state, const texsynth::Preprocessed& result,
                    const texsynth::PreprocessStats& stats) {
  state.counters["K"] = result.num_textons;
  state.counters["features_s"] = stats.features_seconds;
  state.counters["kmeans_s"] = stats.kmeans_seconds;
  state.counters["tables_s"] = stats.tables_seconds;
  state.counters["jumps_s"] = stats.jump_map_seconds;
  state.counters["features_cpu"] = stats.features_cpu;
  state.counters["kmeans_cpu"] = stats.kmeans_cpu;
  state.counters["jumps_cpu"] = stats.jump_map_cpu;
  state.counters["total_cpu"] =
      stats.working_cpu + stats.features_cpu + stats.kmeans_cpu + stats.tables_cpu + stats.jump_map_cpu;
  state.counters["km_iters"] = stats.kmeans_full_iterations;
}

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
  stage_counters(state, result, stats);
  state.counters["cache_B_per_px"] = double(std::filesystem::file_size(path)) / double(size * size);
  std::filesystem::remove(path);
}
BENCHMARK(BM_Preprocess)->Arg(256)->Arg(512)->Arg(1024)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

// Issue 16 rows: a photo-like sample (synthetic_texture.hpp gravel_texture: pebbles 18 px across at
// 512², the same picture with 2x/4x/8x/16x the pixels for the larger sizes, as an upscaled photo),
// preprocessed cold with the defaults (working_size 512). Arg 1 = 1 times the former algorithms in
// the same run (analysis at full resolution, Lloyd on all points). Peak RSS is the process's, so run
// one size per process for memory: --benchmark_filter='BM_PhotoPreprocess/4096/0'.
void BM_PhotoPreprocess(benchmark::State& state) {
  const int size = int(state.range(0));
  const bool former = state.range(1) != 0;
  const texsynth::Image image = texsynth_test::gravel_texture(size, size, 18.0f * float(size) / 512.0f);
  texsynth::PreprocessParams params;
  texsynth::PreprocessVariant variant;
  if (former) {
    params.working_size = 0;
    variant.full_lloyd = true;
  }
  texsynth::PreprocessStats stats;
  texsynth::Preprocessed result;
  for (auto _ : state) result = texsynth::preprocess(image, params, nullptr, &stats, variant);
  stage_counters(state, result, stats);
  state.counters["analysed_px"] = result.width;
  state.counters["scale_s"] = stats.working_seconds;
  state.counters["km_sub_iters"] = stats.kmeans_subsample_iterations;
  state.counters["peak_rss_MB"] = peak_rss_mb();
}
BENCHMARK(BM_PhotoPreprocess)
    ->Args({512, 0})->Args({512, 1})->Args({1024, 0})->Args({1024, 1})->Args({2048, 0})->Args({2048, 1})
    ->Args({4096, 0})->Args({4096, 1})->Args({8192, 0})->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

// Writes the photo-like samples as 8-bit PNGs (to time other builds, e.g. the Python module, on them):
// TEXSYNTH_WRITE_SAMPLES=DIR build/cpp_tests/bench/bench_preprocess --benchmark_filter=BM_WriteSamples
void BM_WriteSamples(benchmark::State& state) {
  const char* dir = std::getenv("TEXSYNTH_WRITE_SAMPLES");
  for (auto _ : state) {
    if (!dir) continue;
    for (int size : {512, 1024, 2048, 4096, 8192}) {
      const texsynth::Image image = texsynth_test::gravel_texture(size, size, 18.0f * float(size) / 512.0f);
      std::vector<uint8_t> bytes(image.pixels.size());
      for (size_t i = 0; i < bytes.size(); ++i) bytes[i] = uint8_t(std::lround(image.pixels[i] * 255.0f));
      texsynth::write_image_u8(std::string(dir) + "/gravel_" + std::to_string(size) + ".png", bytes.data(), size, size, 3);
    }
  }
}
BENCHMARK(BM_WriteSamples)->Iterations(1);

// Choosing the default working size: a 4096² photo-like sample analysed at 256..4096 (11×11 windows in
// analysis pixels). Quality = how alike the full-resolution picture is around a pixel and its best jump
// (mean squared RGB difference over a 65×65 window of ORIGINAL pixels, about a pebble, what a jump puts
// side by side in a render), divided by the same for random pixel pairs: 0 = perfect matches, 1 = no
// better than chance. fine_17px: the same over 17×17 pixels (grain).
void BM_WorkingSizeQuality(benchmark::State& state) {
  const int size = 4096, working = int(state.range(0));
  static const texsynth::Image image = texsynth_test::gravel_texture(size, size, 18.0f * size / 512.0f);
  texsynth::PreprocessParams params;
  params.working_size = working;
  texsynth::Preprocessed r;
  texsynth::PreprocessStats stats;
  for (auto _ : state) r = texsynth::preprocess(image, params, nullptr, &stats);
  const double scale = double(size) / r.width;
  auto window_difference = [&](double ax, double ay, double bx, double by, int radius) {
    double sum = 0;
    int count = 0;
    const int step = std::max(1, radius / 16);
    for (int dy = -radius; dy <= radius; dy += step)
      for (int dx = -radius; dx <= radius; dx += step) {
        const int x0 = int(ax) + dx, y0 = int(ay) + dy, x1 = int(bx) + dx, y1 = int(by) + dy;
        if (x0 < 0 || y0 < 0 || x1 < 0 || y1 < 0 || x0 >= size || y0 >= size || x1 >= size || y1 >= size) continue;
        for (int c = 0; c < 3; ++c) {
          const double d = image.pixels[(size_t(y0) * size + x0) * 3 + c] - image.pixels[(size_t(y1) * size + x1) * 3 + c];
          sum += d * d;
        }
        ++count;
      }
    return count ? sum / count : 0.0;
  };
  texsynth::Rng rng(11);
  double jumps = 0, random = 0, jumps_fine = 0, random_fine = 0;
  const int64_t n = int64_t(r.width) * r.height;
  for (int i = 0; i < 4000; ++i) {
    const int64_t p = int64_t(rng.below(uint32_t(n)));
    const int32_t q = r.jump_map.targets[size_t(p) * r.jump_map.k];
    const int64_t o = int64_t(rng.below(uint32_t(n)));
    auto centre = [&](int64_t at, double& x, double& y) {
      x = (double(at % r.width) + 0.5) * scale;
      y = (double(at / r.width) + 0.5) * scale;
    };
    double px, py, qx, qy, ox, oy;
    centre(p, px, py);
    centre(o, ox, oy);
    random += window_difference(px, py, ox, oy, 32);
    random_fine += window_difference(px, py, ox, oy, 8);
    if (q < 0) continue;
    centre(q, qx, qy);
    jumps += window_difference(px, py, qx, qy, 32);
    jumps_fine += window_difference(px, py, qx, qy, 8);
  }
  state.counters["jump_vs_random"] = jumps / random;
  state.counters["fine_17px"] = jumps_fine / random_fine;
  state.counters["analysis_s"] = stats.features_seconds + stats.kmeans_seconds + stats.tables_seconds +
                                 stats.jump_map_seconds;
  state.counters["scale_s"] = stats.working_seconds;
}
BENCHMARK(BM_WorkingSizeQuality)->Arg(256)->Arg(512)->Arg(1024)->Arg(2048)->Unit(benchmark::kSecond)->Iterations(1)
    ->UseRealTime();

// Cancel latency at every stage of an 8192² sample (validation, hash, scale-down, features, k-means,
// jump map): cancel raised after each delay; latency = raise to throw. Prints the largest.
void BM_CancelLatency(benchmark::State& state) {
  static const texsynth::Image image = texsynth_test::gravel_texture(8192, 8192, 288.0f);
  const texsynth::PreprocessParams params;
  double worst = 0, total = 0;
  for (auto _ : state) {
    const auto whole = std::chrono::steady_clock::now();
    texsynth::preprocess(image, params);
    total = seconds_since(whole);
    for (double fraction = 0.02; fraction < 1.0; fraction += 0.07) {
      std::atomic<bool> cancel{false};
      std::chrono::steady_clock::time_point raised;
      std::thread raiser([&] {
        std::this_thread::sleep_for(std::chrono::duration<double>(total * fraction));
        raised = std::chrono::steady_clock::now();
        cancel = true;
      });
      bool cancelled = false;
      try {
        texsynth::preprocess(image, params, &cancel);
      } catch (const texsynth::Cancelled&) {
        cancelled = true;
      }
      const auto finished = std::chrono::steady_clock::now();
      raiser.join();
      if (cancelled) worst = std::max(worst, std::chrono::duration<double>(finished - raised).count());
    }
  }
  state.counters["uncancelled_s"] = total;
  state.counters["worst_latency_ms"] = worst * 1000.0;
}
BENCHMARK(BM_CancelLatency)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

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
