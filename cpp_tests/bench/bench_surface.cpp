// SPDX-License-Identifier: GPL-3.0-or-later
// sample_texels on a ~70k-triangle UV-unwrapped mesh (a bumpy 187x187-quad sheet cut into 4x4
// islands, every other island mirrored, packed into the unit square with gaps) at 512^2, 1024^2
// and 2048^2, on one and two threads; texels/s counts the image's texels (covered or not).
// warm = 0: every call gets fresh pages from the kernel (as a single call from the add-on does),
// so the time includes first-touch page faults of the returned arrays (44 bytes per sample);
// warm = 1: freed memory is kept and reused, so it measures the computation alone.
#include <benchmark/benchmark.h>
#include <malloc.h>
#include <tbb/global_control.h>

#include <array>
#include <cmath>
#include <vector>

#include "texsynth/surface/texel_samples.hpp"
#include "unwrapped_sheet.hpp"

namespace {

using bench::UnwrappedSheet;

// Args: image side, threads, warm.
void BM_SampleTexels70k(benchmark::State& state) {
  const UnwrappedSheet& m = bench::unwrapped_sheet();
  // Fixed settings (glibc otherwise raises its mmap threshold after the first large free, mixing
  // both regimes): warm = heap only, never trimmed; cold = large blocks mapped and unmapped each time.
  const bool warm = state.range(2) != 0;
  mallopt(M_MMAP_MAX, warm ? 0 : 65536);
  mallopt(M_MMAP_THRESHOLD, 128 * 1024);
  mallopt(M_TRIM_THRESHOLD, warm ? 1 << 30 : 128 * 1024);
  const int32_t side = int32_t(state.range(0));
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, size_t(state.range(1)));
  texsynth::TexelSampleInput in;
  in.positions = m.positions.data();
  in.num_vertices = int32_t(m.positions.size() / 3);
  in.triangles = m.triangles.data();
  in.num_triangles = int32_t(m.triangles.size() / 3);
  in.corner_uvs = m.uvs.data();
  in.width = in.height = side;
  in.margin = 2;
  size_t samples = 0, gutter = 0;
  int32_t islands = 0;
  if (warm) texsynth::sample_texels(in);  // leaves its pages in the heap
  for (auto _ : state) {
    texsynth::TexelSamples s = texsynth::sample_texels(in);
    samples = s.size(), gutter = s.gutter_texel.size(), islands = s.num_islands;
    benchmark::DoNotOptimize(s.texel.data());
  }
  state.counters["texels/s"] =
      benchmark::Counter(double(side) * side * double(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["samples"] = double(samples);
  state.counters["gutter"] = double(gutter);
  state.counters["islands"] = islands;
  state.counters["triangles"] = in.num_triangles;
}
BENCHMARK(BM_SampleTexels70k)
    ->ArgsProduct({{512, 1024, 2048}, {1, 2}, {0, 1}})
    ->ArgNames({"side", "threads", "warm"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
