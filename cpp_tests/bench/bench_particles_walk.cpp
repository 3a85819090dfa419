// SPDX-License-Identifier: GPL-3.0-or-later
// Normal-section walks and pseudo-geodesic distances at the particle-placement scale (issue 15: 20k
// particles on a 100k-face mesh <= 1 s): 20,000 walks of ~5 face diameters, and 20,000 symmetric
// distances between the walks' ends and starts, on a 101,760-face bumpy UV sphere (irregular
// triangles, skinny ones at the poles), at 1 and 2 threads. Reports walks/s and mean faces per walk.
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "bumpy_sphere.hpp"
#include "texsynth/common/rng.hpp"
#include "texsynth/particles/surface_walk.hpp"

namespace {

constexpr int kWalks = 20000;

struct Scene {
  ring_fixtures::TriMesh mesh;
  texsynth::SurfaceWalkMesh s;
  std::vector<texsynth::SectionWalkRequest> walks;
  std::vector<texsynth::SurfacePoint> ends;
  double diameter = 0;
};

const Scene& scene() {
  static Scene sc = [] {
    Scene s;
    s.mesh = bench_fixtures::bumpy_sphere();
    s.s = texsynth::build_surface_walk_mesh(s.mesh.input());
    std::vector<double> cdf;
    double acc = 0, diam = 0;
    for (int32_t t = 0; t < s.mesh.num_triangles(); ++t) {
      const auto a = s.mesh.corner(t, 0), b = s.mesh.corner(t, 1), c = s.mesh.corner(t, 2);
      const texsynth::V3 e1{b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2{c[0] - a[0], c[1] - a[1], c[2] - a[2]};
      cdf.push_back(acc += texsynth::norm(texsynth::cross(e1, e2)));
      diam += std::max({texsynth::norm(e1), texsynth::norm(e2), texsynth::norm(e2 - e1)});
    }
    s.diameter = diam / s.mesh.num_triangles();
    texsynth::Rng rng(5);
    for (int i = 0; i < kWalks; ++i) {
      const int32_t t = int32_t(std::lower_bound(cdf.begin(), cdf.end(), rng.uniform() * acc) - cdf.begin());
      double b1 = rng.uniform(), b2 = rng.uniform();
      if (b1 + b2 > 1) b1 = 1 - b1, b2 = 1 - b2;
      const texsynth::V3 d{rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5};
      s.walks.push_back({{std::min(t, s.mesh.num_triangles() - 1), b1, b2}, d, 5 * s.diameter});
    }
    for (const auto& r : texsynth::walk_normal_sections(s.s.walk, s.s.input(), s.walks.data(), kWalks))
      s.ends.push_back(r.end);
    return s;
  }();
  return sc;
}

void BM_WalkNormalSections(benchmark::State& state) {
  const Scene& sc = scene();
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(state.range(0)));
  std::vector<texsynth::SectionWalkResult> r;
  for (auto _ : state) {
    r = texsynth::walk_normal_sections(sc.s.walk, sc.s.input(), sc.walks.data(), kWalks);
    benchmark::DoNotOptimize(r.data());
  }
  double faces = 0, reached = 0;
  for (const auto& x : r) faces += x.faces, reached += x.status == texsynth::WalkStatus::reached;
  state.counters["triangles"] = sc.mesh.num_triangles();
  state.counters["length/diam"] = sc.walks[0].length / sc.diameter;
  state.counters["faces/walk"] = faces / kWalks;
  state.counters["reached_%"] = 100 * reached / kWalks;
  state.counters["walks/s"] = benchmark::Counter(double(kWalks) * double(state.iterations()), benchmark::Counter::kIsRate);
}

void BM_PseudoGeodesicDistances(benchmark::State& state) {
  const Scene& sc = scene();
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(state.range(0)));
  std::vector<texsynth::SurfacePoint> starts;
  for (const auto& w : sc.walks) starts.push_back(w.start);
  std::vector<texsynth::PseudoGeodesic> d;
  for (auto _ : state) {
    d = texsynth::pseudo_geodesic_distances(sc.s.walk, sc.s.input(), starts.data(), sc.ends.data(), kWalks);
    benchmark::DoNotOptimize(d.data());
  }
  double chord = 0;
  for (const auto& x : d) chord += x.kind == texsynth::DistanceKind::chord;
  state.counters["chord_%"] = 100 * chord / kWalks;
  state.counters["pairs/s"] = benchmark::Counter(double(kWalks) * double(state.iterations()), benchmark::Counter::kIsRate);
}

}  // namespace

BENCHMARK(BM_WalkNormalSections)->ArgNames({"threads"})->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_PseudoGeodesicDistances)->ArgNames({"threads"})->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

BENCHMARK_MAIN();
