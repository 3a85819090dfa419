// SPDX-License-Identifier: GPL-3.0-or-later
#include <benchmark/benchmark.h>

#include "texsynth/common/rng.hpp"

static void BM_RngNextU32(benchmark::State& state) {
  texsynth::Rng r(1);
  for (auto _ : state) benchmark::DoNotOptimize(r.next_u32());
}
BENCHMARK(BM_RngNextU32);
BENCHMARK_MAIN();
