// SPDX-License-Identifier: GPL-3.0-or-later
// Synthesis benchmarks: vertices/s of jump-map synthesis (ordering included) on one core, mesh
// build + synthesis on 1M quads in grid and shuffled order (all threads), the
// bucket-queue order against a std::priority_queue baseline, orientation-field relaxation on a
// 1M-vertex mesh, and (after the Google Benchmark runs) a scaling report 10k -> 4M faces printing
// the fitted time exponent and the extra memory per face (peak heap beyond inputs and outputs).
// Run: build/cpp_tests/bench/bench_synth [--benchmark_filter=...] [--no_scaling]
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <malloc.h>
#include <memory>
#include <map>
#include <utility>
#include <new>

#include "../mesh_fixtures.hpp"
#include "texsynth/field/orientation_field.hpp"
#include "texsynth/synth/jumpmap_synth.hpp"

// ---- heap accounting (live bytes and peak), to measure memory beyond the outputs
namespace {
std::atomic<int64_t> g_live{0}, g_peak{0};
void note_alloc(int64_t n) {
  int64_t now = g_live.fetch_add(n) + n;
  int64_t peak = g_peak.load();
  while (now > peak && !g_peak.compare_exchange_weak(peak, now)) {
  }
}
}  // namespace
void* operator new(size_t n) {
  void* p = std::malloc(n + 16);
  if (!p) throw std::bad_alloc();
  *static_cast<size_t*>(p) = n;
  note_alloc(int64_t(n));
  return static_cast<char*>(p) + 16;
}
void operator delete(void* p) noexcept {
  if (!p) return;
  char* base = static_cast<char*>(p) - 16;
  g_live.fetch_sub(int64_t(*reinterpret_cast<size_t*>(base)));
  std::free(base);
}
void operator delete(void* p, size_t) noexcept { operator delete(p); }
void* operator new[](size_t n) { return operator new(n); }
void operator delete[](void* p) noexcept { operator delete(p); }
void operator delete[](void* p, size_t) noexcept { operator delete(p); }

namespace {

const texsynth::Preprocessed& sample() {
  static texsynth::Preprocessed pre = fixtures::planted(256, 256, 4, 0.9f, false, 8);
  return pre;
}

// Triangle grid with about `faces` faces, jittered, 1 unit per cell; or a noisy UV sphere.
fixtures::TestMesh make_mesh(int64_t faces, bool sphere) {
  if (sphere) {
    int rings = int(std::sqrt(double(faces) / 4.0)) + 2;
    return fixtures::uv_sphere(rings, 2 * rings, 1.0, 0.05);
  }
  int n = int(std::sqrt(double(faces) / 2.0));
  return fixtures::grid(n, n, 1.0, true, 0.4);
}

struct Prepared {
  fixtures::TestMesh t;
  texsynth::Mesh mesh;
  std::vector<float> up;
  double scale;
};

Prepared& prepared(int64_t faces, bool sphere) {
  static std::map<std::pair<int64_t, bool>, Prepared> cache;
  auto key = std::make_pair(faces, sphere);
  auto it = cache.find(key);
  if (it != cache.end()) return it->second;
  if (cache.size() > 2) cache.clear();  // keep memory bounded
  Prepared& p = cache[key];
  p.t = make_mesh(faces, sphere);
  p.mesh = texsynth::build_mesh(p.t.input());
  p.up = texsynth::compute_orientation_field(p.mesh, texsynth::FieldParams());
  // ~2 texels per edge on the grid; the sphere's edges are ~pi/rings long.
  p.scale = sphere ? 2.0 / (3.14159 / std::sqrt(double(faces) / 4.0)) : 2.0;
  return p;
}

texsynth::JumpSynthResult synth(const Prepared& p) {
  texsynth::JumpSynthParams params;
  params.scale = p.scale;
  params.seed = 1;
  return texsynth::synthesize_jumpmap(sample(), p.mesh, p.up.data(), params);
}

void BM_SynthesizeOneCore(benchmark::State& state) {
  tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
  Prepared& p = prepared(state.range(0), state.range(1) != 0);
  for (auto _ : state) benchmark::DoNotOptimize(synth(p));
  state.SetItemsProcessed(state.iterations() * p.mesh.num_vertices);
  state.counters["faces"] = p.mesh.num_polys;
}
BENCHMARK(BM_SynthesizeOneCore)
    ->ArgsProduct({{10000, 160000, 1000000}, {0, 1}})
    ->ArgNames({"faces", "sphere"})
    ->Unit(benchmark::kMillisecond);

// The whole native call as the add-on makes it (build_mesh + synthesize_jumpmap, all threads) on
// ~1M jittered quads (the bunny's size and polygon type), grid-ordered or shuffled.
void BM_MeshAndSynthesize(benchmark::State& state) {
  static std::map<int64_t, std::pair<fixtures::TestMesh, std::vector<float>>> meshes;
  auto& [t, up] = meshes[state.range(1)];
  if (t.poly_starts.empty()) {
    const int n = int(std::sqrt(double(state.range(0))));
    t = fixtures::grid(n, n, 1.0, false, 0.4);
    if (state.range(1)) t = fixtures::shuffled(t, 7, false);
    up = texsynth::compute_orientation_field(texsynth::build_mesh(t.input()), texsynth::FieldParams());
  }
  texsynth::JumpSynthParams params;
  params.scale = 2.0;
  params.seed = 1;
  params.baseline_passes = state.range(2) != 0;
  std::unique_ptr<tbb::global_control> one;
  if (state.range(3) == 1) one = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, 1);
  double faces = 0, walk = 0, corners = 0;  // phase seconds (JumpSynthResult::stats)
  for (auto _ : state) {
    texsynth::Mesh mesh = texsynth::build_mesh(t.input());
    const texsynth::JumpSynthResult r = texsynth::synthesize_jumpmap(sample(), mesh, up.data(), params);
    benchmark::DoNotOptimize(r);
    faces += r.stats.seconds_faces, walk += r.stats.seconds_walk, corners += r.stats.seconds_corners;
  }
  state.counters["faces_s"] = faces / double(state.iterations());
  state.counters["walk_s"] = walk / double(state.iterations());
  state.counters["corners_s"] = corners / double(state.iterations());
  state.SetItemsProcessed(state.iterations() * t.num_vertices());
  state.counters["faces"] = double(t.poly_starts.size());
}
BENCHMARK(BM_MeshAndSynthesize)
    ->ArgsProduct({{1000000}, {0, 1}, {1, 0}, {0, 1}})
    ->ArgNames({"faces", "shuffled", "baseline_passes", "one_thread"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_OrderBucketQueue(benchmark::State& state) {
  Prepared& p = prepared(state.range(0), false);
  for (auto _ : state) benchmark::DoNotOptimize(texsynth::region_growing_order(p.mesh, 1));
  state.SetItemsProcessed(state.iterations() * p.mesh.num_vertices);
}
void BM_OrderPriorityQueueBaseline(benchmark::State& state) {
  Prepared& p = prepared(state.range(0), false);
  for (auto _ : state) benchmark::DoNotOptimize(texsynth::region_growing_order_heap(p.mesh, 1));
  state.SetItemsProcessed(state.iterations() * p.mesh.num_vertices);
}
BENCHMARK(BM_OrderBucketQueue)->Arg(1000000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_OrderPriorityQueueBaseline)->Arg(1000000)->Unit(benchmark::kMillisecond);

// Field relaxation on a ~1M-vertex noisy sphere: anchors + a source + a sink, propagated and
// smoothed. threads = 1 is the serial baseline for the parallel Jacobi smoothing.
void BM_FieldRelaxation1M(benchmark::State& state) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, size_t(state.range(0)));
  static fixtures::TestMesh t = fixtures::uv_sphere(708, 1414, 1.0, 0.02);  // ~1.0M vertices
  static texsynth::Mesh mesh = texsynth::build_mesh(t.input());
  texsynth::FieldParams fp;
  fp.mode = texsynth::OrientationMode::Anchors;
  fp.anchor_vertices = {1000, 500000};
  fp.anchor_directions = {{1.f, 0.f, 0.f}, {0.f, 1.f, 0.f}};
  fp.sources = {0};
  fp.sinks = {mesh.num_vertices - 1};
  for (auto _ : state) benchmark::DoNotOptimize(texsynth::compute_orientation_field(mesh, fp));
  state.SetItemsProcessed(state.iterations() * mesh.num_vertices);
  state.counters["vertices"] = mesh.num_vertices;
}
BENCHMARK(BM_FieldRelaxation1M)->Arg(1)->Arg(2)->ArgName("threads")->Unit(benchmark::kMillisecond);

// Process CPU time: with one TBB thread all work runs on this thread, and other processes on the
// shared machine do not inflate it the way they inflate wall time.
double cpu_seconds() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

// Scaling report: best-of-N CPU time per size on one core, least-squares slope of log t vs log F.
void scaling_report(bool sphere, const char* memory) {
  tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
  const int64_t sizes[] = {10000, 40000, 160000, 640000, 2000000, 4000000};
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  int count = 0;
  std::printf("\nscaling (%s, %s, one core, CPU time): faces vertices seconds Mvertices/s extra_bytes/face\n", sphere ? "noisy sphere" : "jittered grid", memory);
  for (int64_t target : sizes) {
    Prepared& p = prepared(target, sphere);
    double best = 1e30;
    int reps = target <= 640000 ? 5 : 2;
    for (int r = 0; r < reps; ++r) {
      const double t0 = cpu_seconds();
      benchmark::DoNotOptimize(synth(p));
      best = std::min(best, cpu_seconds() - t0);
    }
    // Memory of the whole call as the Python binding does it (mesh adjacency + field + synthesis),
    // minus the returned CornerMaps; vertex_address (8 B/vertex) is counted as overhead.
    int64_t extra = 0;
    {
      int64_t before = g_live.load();
      g_peak.store(before);
      texsynth::Mesh mesh = texsynth::build_mesh(p.t.input());
      std::vector<float> up = texsynth::compute_orientation_field(mesh, texsynth::FieldParams());
      texsynth::JumpSynthParams params;
      params.scale = p.scale;
      auto res = texsynth::synthesize_jumpmap(sample(), mesh, up.data(), params);
      int64_t outputs = int64_t(res.maps.base_uv.capacity() + res.maps.blend_uv.capacity() +
                                res.maps.blend_weights.capacity()) * 4;
      extra = g_peak.load() - before - outputs;
    }
    const double faces = p.mesh.num_polys;
    std::printf("  %9.0f %9d %8.4f %8.2f %8.1f\n", faces, p.mesh.num_vertices, best, p.mesh.num_vertices / best / 1e6,
                double(extra) / faces);
    double x = std::log(faces), y = std::log(best);
    sx += x, sy += y, sxx += x * x, sxy += x * y, ++count;
  }
  double slope = (count * sxy - sx * sy) / (count * sxx - sx * sx);
  std::printf("  fitted exponent t ~ faces^%.3f (1.0 = linear)\n", slope);
}

}  // namespace

int main(int argc, char** argv) {
  bool scaling = true;
  for (int i = 1; i < argc; ++i)
    if (std::strcmp(argv[i], "--no_scaling") == 0) scaling = false, argv[i] = argv[0];
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  if (scaling) {
    // Default glibc malloc: buffers above its mmap threshold (<= 32 MB) come fresh from the kernel
    // on every call, so large meshes also pay page faults + page zeroing (as a first call does).
    scaling_report(false, "default malloc");
    scaling_report(true, "default malloc");
    // Heap reuse for every size: the compute-only scaling.
    mallopt(M_MMAP_MAX, 0);  // never mmap: everything from the (reused) heap
    mallopt(M_TRIM_THRESHOLD, 1 << 30);
    scaling_report(false, "heap reuse");
    scaling_report(true, "heap reuse");
  }
  return 0;
}
