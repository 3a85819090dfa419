// SPDX-License-Identifier: GPL-3.0-or-later
// Exemplar analysis for vector-field patches (patches/exemplar_index.hpp) on real samples:
// blend_samples/bricks.png cropped to 96² (the paper's size) and resized to 256² (bilinear; the 5 s
// goal on 2 cores of vector_field_patches.md, "Exemplar analysis"), and moss.png (160²).
//
// BM_ExemplarBuild/size/band: preprocessing seconds (appearance, patch PCA, HNSW) for 32² patches,
//   memory of the result, serialized bytes and the load time (checks + graph restoration).
// BM_ExemplarQuery/sample/ef_construction/ef_search: HNSW vs exhaustive search on the full index at
//   32² patches: recall@1 (HNSW's first = the exact first) and recall@16 (share of the exact 16 that
//   HNSW returns), HNSW's first distance / the exact first (mean, max), microseconds per query
//   single-threaded, for two query sets:
//   "noisy" = an origin's reduced vector + Gaussian noise of 10 % of the data's RMS per dim;
//   "blend" = the mean of two random origins' vectors (a patch mixing two sources, as a
//   synthesized surface patch is).
// Run: build-exemplar/cpp_tests/bench/bench_patches_exemplar [--benchmark_filter=...]
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "texsynth/common/rng.hpp"
#include "texsynth/image_files/image_files.hpp"
#include "texsynth/patches/exemplar_cache.hpp"
#include "texsynth/patches/exemplar_index.hpp"

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

struct Sample {
  int width = 0, height = 0, channels = 0;
  std::vector<float> pixels;  // row 0 at the bottom
  texsynth::ExemplarSample view() const { return {pixels.data(), width, height, channels}; }
};

// blend_samples/ found from this file's path (the bench CMake file defines no data directory).
std::string sample_path(const std::string& name) {
  const std::string here = __FILE__;
  return here.substr(0, here.rfind("cpp_tests/bench/")) + "blend_samples/" + name;
}

Sample load(const std::string& name) {
  const texsynth::Image image = texsynth::load_image(sample_path(name));
  Sample s{image.width, image.height, image.channels, {}};
  s.pixels.resize(image.pixels.size());
  const size_t row = size_t(image.width) * size_t(image.channels);
  for (int y = 0; y < image.height; ++y)  // image rows are top-first; the sample's are bottom-first
    std::copy_n(image.pixels.begin() + ptrdiff_t(size_t(image.height - 1 - y) * row), row,
                s.pixels.begin() + ptrdiff_t(size_t(y) * row));
  return s;
}

Sample crop(const Sample& in, int size) {
  Sample s{size, size, in.channels, std::vector<float>(size_t(size) * size * in.channels)};
  const int x0 = (in.width - size) / 2, y0 = (in.height - size) / 2;
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x)
      for (int c = 0; c < in.channels; ++c)
        s.pixels[(size_t(y) * size + x) * in.channels + c] =
            in.pixels[(size_t(y + y0) * in.width + x + x0) * in.channels + c];
  return s;
}

Sample resize(const Sample& in, int size) {
  Sample s{size, size, in.channels, std::vector<float>(size_t(size) * size * in.channels)};
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      const float fx = std::clamp((x + 0.5f) * in.width / size - 0.5f, 0.f, float(in.width - 1));
      const float fy = std::clamp((y + 0.5f) * in.height / size - 0.5f, 0.f, float(in.height - 1));
      const int x0 = int(fx), y0 = int(fy), x1 = std::min(x0 + 1, in.width - 1), y1 = std::min(y0 + 1, in.height - 1);
      const float tx = fx - x0, ty = fy - y0;
      for (int c = 0; c < in.channels; ++c) {
        auto p = [&](int xx, int yy) { return in.pixels[(size_t(yy) * in.width + xx) * in.channels + c]; };
        s.pixels[(size_t(y) * size + x) * in.channels + c] =
            (p(x0, y0) * (1 - tx) + p(x1, y0) * tx) * (1 - ty) + (p(x0, y1) * (1 - tx) + p(x1, y1) * tx) * ty;
      }
    }
  return s;
}

const Sample& sample(int which) {
  static const Sample bricks = load("bricks.png");
  static const Sample bricks96 = crop(bricks, 96);
  static const Sample bricks256 = resize(bricks, 256);
  static const Sample moss = load("moss.png");
  switch (which) {
    case 96: return bricks96;
    case 256: return bricks256;
    case 160: return moss;
    default: return bricks;
  }
}

void BM_ExemplarBuild(benchmark::State& state) {
  const Sample& s = sample(int(state.range(0)));
  texsynth::ExemplarParams p;
  p.band_index = state.range(1) != 0;
  texsynth::ExemplarIndex index;
  for (auto _ : state) index = texsynth::build_exemplar_index(s.view(), p);
  const auto bytes = texsynth::serialize_exemplar_index(index);
  const auto t0 = Clock::now();
  const auto loaded = texsynth::deserialize_exemplar_index(bytes.data(), bytes.size(), index.key);
  const double load_s = seconds_since(t0);
  state.counters["origins"] = index.full->count();
  state.counters["appearance_s"] = index.stats.seconds_appearance;
  state.counters["features_s"] = index.stats.seconds_features;
  state.counters["hnsw_s"] = index.stats.seconds_hnsw;
  state.counters["total_s"] = index.stats.seconds_total;
  state.counters["index_MB"] = double(index.stats.index_bytes) / 1e6;
  state.counters["estimate_MB"] = double(index.stats.estimated_bytes) / 1e6;
  state.counters["file_MB"] = double(bytes.size()) / 1e6;
  state.counters["load_s"] = load_s;
  std::printf("build %dx%d band=%d: total %.3f s (appearance %.3f, features %.3f, hnsw %.3f), %d origins, "
              "index %.1f MB (estimate %.1f), file %.1f MB, load %.3f s (graph restoration %.3f)\n",
              s.width, s.height, int(p.band_index), index.stats.seconds_total, index.stats.seconds_appearance,
              index.stats.seconds_features, index.stats.seconds_hnsw, index.full->count(),
              double(index.stats.index_bytes) / 1e6, double(index.stats.estimated_bytes) / 1e6,
              double(bytes.size()) / 1e6, load_s, loaded.stats.seconds_hnsw);
}
BENCHMARK(BM_ExemplarBuild)
    ->Args({96, 0})
    ->Args({96, 1})
    ->Args({256, 0})
    ->Args({256, 1})
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->UseRealTime();

struct QuerySet {
  const char* name;
  std::vector<float> vectors;
};

std::vector<QuerySet> make_queries(const texsynth::PatchIndex& ix, int n, uint64_t seed) {
  const int D = ix.dims;
  std::vector<double> rms(size_t(D), 0.0);
  for (int32_t i = 0; i < ix.count(); ++i)
    for (int d = 0; d < D; ++d) rms[size_t(d)] += double(ix.reduced_at(i)[d]) * ix.reduced_at(i)[d];
  for (auto& r : rms) r = std::sqrt(r / ix.count());
  texsynth::Rng rng(seed);
  auto gauss = [&]() {
    const double u1 = std::max(1e-12, rng.uniform()), u2 = rng.uniform();
    return std::sqrt(-2 * std::log(u1)) * std::cos(6.283185307179586 * u2);
  };
  QuerySet noisy{"noisy", std::vector<float>(size_t(n) * D)}, blend{"blend", std::vector<float>(size_t(n) * D)};
  for (int q = 0; q < n; ++q) {
    const float* a = ix.reduced_at(int32_t(rng.below(uint32_t(ix.count()))));
    const float* b = ix.reduced_at(int32_t(rng.below(uint32_t(ix.count()))));
    const float* c = ix.reduced_at(int32_t(rng.below(uint32_t(ix.count()))));
    for (int d = 0; d < D; ++d) {
      noisy.vectors[size_t(q) * D + d] = float(a[d] + 0.1 * rms[size_t(d)] * gauss());
      blend.vectors[size_t(q) * D + d] = 0.5f * (b[d] + c[d]);
    }
  }
  return {noisy, blend};
}

void BM_ExemplarQuery(benchmark::State& state) {
  const Sample& s = sample(int(state.range(0)));
  texsynth::ExemplarParams p;
  p.hnsw.ef_construction = int(state.range(1));
  p.hnsw.ef_search = int(state.range(2));
  const texsynth::ExemplarIndex index = texsynth::build_exemplar_index(s.view(), p);
  const texsynth::PatchIndex& ix = *index.full;
  const int n = 1000, k = 16;
  tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
  for (auto _ : state) {
    for (const QuerySet& set : make_queries(ix, n, 11)) {
      double hnsw_s = 0, exact_s = 0, r1 = 0, r16 = 0, ratio = 0, worst_ratio = 1;
      for (int q = 0; q < n; ++q) {
        const float* v = set.vectors.data() + size_t(q) * ix.dims;
        auto t0 = Clock::now();
        const auto approx = ix.search(v, k);
        hnsw_s += seconds_since(t0);
        t0 = Clock::now();
        const auto exact = ix.search_exact(v, k);
        exact_s += seconds_since(t0);
        // Same origin, or the same distance (ties between equal patches count as found).
        r1 += (approx[0].x == exact[0].x && approx[0].y == exact[0].y) ||
              approx[0].distance2 <= exact[0].distance2 * (1 + 1e-5f) + 1e-9f;
        // How much worse HNSW's first is than the true first (1 = as good).
        const double rq = exact[0].distance2 > 0 ? double(approx[0].distance2) / exact[0].distance2 : 1.0;
        ratio += rq;
        worst_ratio = std::max(worst_ratio, rq);
        int found = 0;
        for (const auto& e : exact)
          for (const auto& a : approx) found += (a.x == e.x && a.y == e.y);
        r16 += double(found) / double(exact.size());
      }
      const auto t0 = Clock::now();
      const auto batch = ix.search_batch(set.vectors.data(), n, k, true);
      const double batch_s = seconds_since(t0);
      const std::string prefix = std::string(set.name) + "_";
      state.counters[prefix + "recall1"] = r1 / n;
      state.counters[prefix + "recall16"] = r16 / n;
      state.counters[prefix + "d1_ratio"] = ratio / n;
      state.counters[prefix + "hnsw_us"] = 1e6 * hnsw_s / n;
      state.counters[prefix + "exact_us"] = 1e6 * exact_s / n;
      state.counters[prefix + "exact_batch_us"] = 1e6 * batch_s / n;
      std::printf("query %dx%d efc=%d efs=%d %s: recall@1 %.3f recall@16 %.3f, d1 HNSW/exact mean %.4f max %.3f, "
                  "HNSW %.1f us, exact %.1f us (batched GEMM %.1f us) per query, 1 thread, %d origins; "
                  "build %.2f s (hnsw %.2f)\n",
                  s.width, s.height, p.hnsw.ef_construction, p.hnsw.ef_search, set.name, r1 / n, r16 / n,
                  ratio / n, worst_ratio,
                  1e6 * hnsw_s / n, 1e6 * exact_s / n, 1e6 * batch_s / n, ix.count(), index.stats.seconds_total,
                  index.stats.seconds_hnsw);
      (void)batch;
    }
  }
}
BENCHMARK(BM_ExemplarQuery)
    ->ArgsProduct({{192, 160}, {32, 64, 100}, {32, 64, 128}})
    ->Args({96, 64, 64})
    ->Args({256, 64, 64})
    ->Args({256, 100, 128})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
