// SPDX-License-Identifier: GPL-3.0-or-later
// Texton-string synthesis benchmarks. Google Benchmark: faces/s on one core (256×256 brick sample,
// preprocessed for real) for texton vs the jump-map synthesizer in the same run. Then two printed
// reports: (1) quality: mean and 95th-percentile E_t over interior edges, texton vs jump map on the
// same meshes, for a structured (bricks) and a stochastic (value noise) sample; (2) scaling
// 10k -> 1M faces on one core (best-of-N process CPU time) with the fitted exponent.
// (3) growth: the original path against coherent candidates and parallel regions, E_t and 2-thread speed.
// Run: build/cpp_tests/bench/bench_texton [--benchmark_filter=...] [--no_reports | --growth_only]
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <map>
#include <vector>

#include "../mesh_fixtures.hpp"
#include "../synthetic_texture.hpp"
#include "texsynth/field/orientation_field.hpp"
#include "texsynth/mesh/mesh_edges.hpp"
#include "texsynth/preprocess/preprocess.hpp"
#include "texsynth/synth/jumpmap_synth.hpp"
#include "texsynth/synth/texton_synth.hpp"

namespace {

// Stochastic sample: three octaves of value noise, per-channel offsets.
texsynth::Image noise_texture(int width, int height, uint64_t seed) {
  texsynth::Image image;
  image.width = width, image.height = height, image.channels = 3;
  image.encoding = texsynth::ColorEncoding::kSrgb;
  image.pixels.resize(size_t(width) * height * 3);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const float n = 0.5f * texsynth_test::value_noise(float(x), float(y), 9.f, seed) +
                      0.3f * texsynth_test::value_noise(float(x), float(y), 4.f, seed + 1) +
                      0.2f * texsynth_test::value_noise(float(x), float(y), 2.f, seed + 2);
      const float rgb[3] = {0.2f + 0.6f * n, 0.3f + 0.4f * n, 0.1f + 0.3f * n};
      for (int c = 0; c < 3; ++c) image.pixels[(size_t(y) * width + x) * 3 + c] = rgb[c];
    }
  return image;
}

struct Sample {
  texsynth::Image image;
  texsynth::Preprocessed pre;
  texsynth::SampleImage view() const { return {image.pixels.data(), image.width, image.height, image.channels}; }
};

Sample make_sample(texsynth::Image image) {
  Sample s;
  s.image = std::move(image);
  texsynth::PreprocessParams params;
  params.jump_candidates = 4;
  s.pre = texsynth::preprocess(s.image, params);
  return s;
}

const Sample& bricks256() {
  static Sample s = make_sample(texsynth_test::brick_texture(256, 256, 1));
  return s;
}

struct Prepared {
  fixtures::TestMesh t;
  texsynth::Mesh mesh;
  std::vector<float> up;
};

// Jittered triangle grid with about `faces` faces, 1 unit per cell.
Prepared& prepared(int64_t faces) {
  static std::map<int64_t, Prepared> cache;
  auto it = cache.find(faces);
  if (it != cache.end()) return it->second;
  if (cache.size() > 1) cache.clear();
  Prepared& p = cache[faces];
  const int n = int(std::sqrt(double(faces) / 2.0));
  p.t = fixtures::grid(n, n, 1.0, true, 0.4);
  p.mesh = texsynth::build_mesh(p.t.input());
  p.up = texsynth::compute_orientation_field(p.mesh, texsynth::FieldParams());
  return p;
}

// Growth configuration: coherence_threshold and seeds_per_component (0, 1 = the original path).
struct Growth {
  double coherence = 0;
  int seeds = 1;
  int threads = 2;  // speed runs only
};
constexpr Growth kOldGrowth{0.0, 1};

texsynth::TextonSynthResult texton(const Sample& s, const Prepared& p, double scale, uint64_t seed = 1,
                                   Growth growth = kOldGrowth) {
  texsynth::TextonSynthParams params;
  params.scale = scale;
  params.seed = seed;
  params.search.coherence_threshold = growth.coherence;
  params.seeds_per_component = growth.seeds;
  return texsynth::synthesize_texton(s.pre, p.mesh, p.up.data(), s.view(), params);
}

texsynth::JumpSynthResult jumpmap(const Sample& s, const Prepared& p, double scale, uint64_t seed = 1) {
  texsynth::JumpSynthParams params;
  params.scale = scale;
  params.seed = seed;
  return texsynth::synthesize_jumpmap(s.pre, p.mesh, p.up.data(), params);
}

constexpr double kSpeedScale = 4.0;  // texels per grid cell in the speed runs

void BM_TextonOneCore(benchmark::State& state) {
  tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
  const Sample& s = bricks256();
  Prepared& p = prepared(state.range(0));
  for (auto _ : state) benchmark::DoNotOptimize(texton(s, p, kSpeedScale));
  state.SetItemsProcessed(state.iterations() * p.mesh.num_polys);
}
void BM_JumpmapOneCoreBaseline(benchmark::State& state) {
  tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
  const Sample& s = bricks256();
  Prepared& p = prepared(state.range(0));
  for (auto _ : state) benchmark::DoNotOptimize(jumpmap(s, p, kSpeedScale));
  state.SetItemsProcessed(state.iterations() * p.mesh.num_polys);
}
BENCHMARK(BM_TextonOneCore)->Arg(100000)->ArgName("faces")->Unit(benchmark::kMillisecond);
BENCHMARK(BM_JumpmapOneCoreBaseline)->Arg(100000)->ArgName("faces")->Unit(benchmark::kMillisecond);

double cpu_seconds() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

struct Summary {
  double mean = 0, p95 = 0;
};
Summary summarize(const std::vector<float>& error, const texsynth::MeshEdges& edges) {
  std::vector<float> interior;
  for (int32_t e = 0; e < edges.num_edges(); ++e)
    if (edges.edge_corner_start[e + 1] - edges.edge_corner_start[e] >= 2) interior.push_back(error[e]);
  Summary s;
  for (float v : interior) s.mean += v;
  s.mean /= double(interior.size());
  std::sort(interior.begin(), interior.end());
  s.p95 = interior[size_t(0.95 * double(interior.size() - 1))];
  return s;
}

// The quality reports' 160×160 samples (bricks, value noise) and meshes (~3.3k triangles each, with
// their scale in texels per unit).
std::array<Sample, 2> quality_samples() {
  return {make_sample(texsynth_test::brick_texture(160, 160, 4)), make_sample(noise_texture(160, 160, 4))};
}
struct MeshCase {
  const char* name;
  fixtures::TestMesh t;
  double scale;
};
std::array<MeshCase, 3> quality_meshes() {
  return {MeshCase{"jittered grid 3.2k, 8/cell", fixtures::grid(40, 40, 1.0, true, 0.4), 8.0},
          MeshCase{"jittered grid 3.2k, 16/cell", fixtures::grid(40, 40, 1.0, true, 0.4), 16.0},
          MeshCase{"noisy sphere 3.4k", fixtures::uv_sphere(30, 58, 1.0, 0.05), 120.0}};
}

void quality_report() {
  std::printf("\nquality: E_t over interior edges (mean / p95; lower = fewer seams), 5 seeds pooled by mean\n");
  std::printf("  %-26s %-28s %8s %21s %21s\n", "sample (160x160)", "mesh", "texels/cell", "texton mean / p95",
              "jump map mean / p95");
  const std::array<Sample, 2> samples = quality_samples();
  const char* names[2] = {"bricks (structured)", "value noise (stochastic)"};
  std::array<MeshCase, 3> meshes = quality_meshes();
  for (int si = 0; si < 2; ++si)
    for (auto& mc : meshes) {
      Prepared p;
      p.mesh = texsynth::build_mesh(mc.t.input());
      p.up = texsynth::compute_orientation_field(p.mesh, texsynth::FieldParams());
      const texsynth::MeshEdges edges = texsynth::build_mesh_edges(p.mesh);
      Summary t_sum, j_sum;
      const int seeds = 5;
      for (uint64_t seed = 1; seed <= seeds; ++seed) {
        auto tr = texton(samples[si], p, mc.scale, seed);
        auto jr = jumpmap(samples[si], p, mc.scale, seed);
        const Summary a = summarize(tr.edge_error, tr.edges);
        const Summary b = summarize(
            texsynth::edge_continuity_error(p.mesh, edges, jr.maps.base_uv.data(), samples[si].view(), false), edges);
        t_sum.mean += a.mean / seeds, t_sum.p95 += a.p95 / seeds, j_sum.mean += b.mean / seeds, j_sum.p95 += b.p95 / seeds;
      }
      std::printf("  %-26s %-28s %8.0f %10.4f / %8.4f %10.4f / %8.4f\n", names[si], mc.name, mc.scale, t_sum.mean,
                  t_sum.p95, j_sum.mean, j_sum.p95);
    }
}

void scaling_report() {
  tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
  const Sample& s = bricks256();
  const int64_t sizes[] = {10000, 31600, 100000, 316000, 1000000};
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  int count = 0;
  std::printf("\nscaling (texton, 256x256 bricks, K=%d, jittered grid, %.0f texels/cell, one core, CPU time):\n",
              s.pre.num_textons, kSpeedScale);
  std::printf("  %9s %9s %12s %12s\n", "faces", "seconds", "faces/s", "jump map f/s");
  for (int64_t target : sizes) {
    Prepared& p = prepared(target);
    double best = 1e30, best_j = 1e30;
    const int reps = target <= 100000 ? 3 : 1;
    for (int r = 0; r < reps; ++r) {
      double t0 = cpu_seconds();
      benchmark::DoNotOptimize(texton(s, p, kSpeedScale));
      best = std::min(best, cpu_seconds() - t0);
      t0 = cpu_seconds();
      benchmark::DoNotOptimize(jumpmap(s, p, kSpeedScale));
      best_j = std::min(best_j, cpu_seconds() - t0);
    }
    const double faces = p.mesh.num_polys;
    std::printf("  %9.0f %9.4f %12.0f %12.0f\n", faces, best, faces / best, faces / best_j);
    const double x = std::log(faces), y = std::log(best);
    sx += x, sy += y, sxx += x * x, sxy += x * y, ++count;
  }
  std::printf("  fitted exponent t ~ faces^%.3f (1.0 = linear)\n", (count * sxy - sx * sy) / (count * sxx - sx * sx));
}

double wall_seconds() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

// Original growth vs coherent candidates / parallel regions in the same run: E_t on the quality
// meshes (5 seeds) and wall-clock faces/s on 2 threads (configurations alternate; median of 3).
void growth_report(const std::vector<Growth>& configs) {
  std::printf("\ngrowth: coherence_threshold:seeds_per_component (0:1 = original path), same run\n");
  std::printf("  E_t mean / p95 over interior edges, 5 seeds, 160x160 samples\n");
  const std::array<Sample, 2> samples = quality_samples();
  const char* names[2] = {"bricks", "value noise"};
  std::array<MeshCase, 3> meshes = quality_meshes();
  std::printf("  %-12s %-28s", "sample", "mesh");
  for (const Growth& g : configs)
    if (g.threads == 2) std::printf("  %8g:%-4d     ", g.coherence, g.seeds);
  std::printf("\n");
  for (int si = 0; si < 2; ++si)
    for (auto& mc : meshes) {
      Prepared p;
      p.mesh = texsynth::build_mesh(mc.t.input());
      p.up = texsynth::compute_orientation_field(p.mesh, texsynth::FieldParams());
      std::printf("  %-12s %-28s", names[si], mc.name);
      for (const Growth& g : configs) {
        if (g.threads != 2) continue;  // same output at any thread count
        Summary sum;
        for (uint64_t seed = 1; seed <= 5; ++seed) {
          const auto r = texton(samples[si], p, mc.scale, seed, g);
          const Summary a = summarize(r.edge_error, r.edges);
          sum.mean += a.mean / 5, sum.p95 += a.p95 / 5;
        }
        std::printf("  %.4f / %.4f", sum.mean, sum.p95);
      }
      std::printf("\n");
    }
  const Sample& s = bricks256();
  Prepared& p = prepared(1000000);
  std::printf("  speed, 256x256 bricks, jittered grid %d faces, %.0f texels/cell, wall clock median of 3 [range], process CPU median:\n",
              p.mesh.num_polys, kSpeedScale);
  std::vector<std::vector<double>> times(configs.size()), cpu(configs.size());
  std::vector<Summary> quality(configs.size());
  for (int rep = 0; rep < 3; ++rep)
    for (size_t i = 0; i < configs.size(); ++i) {
      tbb::global_control threads(tbb::global_control::max_allowed_parallelism, size_t(configs[i].threads));
      const double t0 = wall_seconds(), c0 = cpu_seconds();
      const auto r = texton(s, p, kSpeedScale, 1, configs[i]);
      times[i].push_back(wall_seconds() - t0);
      cpu[i].push_back(cpu_seconds() - c0);
      quality[i] = summarize(r.edge_error, r.edges);
    }
  for (size_t i = 0; i < configs.size(); ++i) {
    std::sort(times[i].begin(), times[i].end());
    std::sort(cpu[i].begin(), cpu[i].end());
    std::printf("    %8g:%-4d %d thr %7.3f s [%.3f-%.3f] %10.0f faces/s  CPU %.3f s  E_t %.4f / %.4f\n", configs[i].coherence,
                configs[i].seeds, configs[i].threads, times[i][1], times[i][0], times[i][2], p.mesh.num_polys / times[i][1], cpu[i][1],
                quality[i].mean, quality[i].p95);
  }
}

}  // namespace

int main(int argc, char** argv) {
  bool reports = true, growth_only = false;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--no_reports") == 0) reports = false, argv[i] = argv[0];
    if (std::strcmp(argv[i], "--growth_only") == 0) growth_only = true, argv[i] = argv[0];
  }
  const std::vector<Growth> growth = {kOldGrowth, {0.5, 1}, {0.0, 16}, {0.5, 16}, {0.5, 16, 1}};
  if (growth_only) {
    growth_report(growth);
    return 0;
  }
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  if (reports) {
    quality_report();
    scaling_report();
    growth_report(growth);
  }
  return 0;
}
