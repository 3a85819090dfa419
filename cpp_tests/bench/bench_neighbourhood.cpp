// SPDX-License-Identifier: GPL-3.0-or-later
// Round-ring precomputation at the 1024² target's size: ~700k random surface points on an 81,920-face
// noise-displaced icosphere (subdivision 6), r = sqrt(area / points) (about the texel spacing),
// K = 4 and K = 2, at 1 and 2 threads. Reports points/s and bytes/point.
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

#include "../neighbourhood_fixtures.hpp"
#include "texsynth/neighbourhood/round_rings.hpp"

namespace {

constexpr int32_t kPoints = 700000;

struct Scene {
  ring_fixtures::TriMesh mesh;
  ring_fixtures::Points points, sorted;  // random order; grouped by triangle as texels of a UV map come
};

const Scene& scene() {
  static Scene s = [] {
    Scene sc;
    sc.mesh = ring_fixtures::icosphere(6, 1.0);
    // Smooth bumps of ±3 % of the radius: curved, irregular faces, no symmetry to exploit.
    for (int32_t v = 0; v < sc.mesh.num_vertices(); ++v) {
      float* p = &sc.mesh.positions[3 * size_t(v)];
      const double x = p[0], y = p[1], z = p[2];
      const double k = 1 + 0.03 * std::sin(7 * x + 1) * std::sin(5 * y + 2) * std::sin(6 * z + 3);
      for (int j = 0; j < 3; ++j) p[j] = float(p[j] * k);
    }
    double area = 0;
    for (int32_t t = 0; t < sc.mesh.num_triangles(); ++t) {
      auto a = sc.mesh.corner(t, 0), b = sc.mesh.corner(t, 1), c = sc.mesh.corner(t, 2);
      const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
      const double n[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
      area += 0.5 * std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    }
    sc.points = ring_fixtures::random_points(sc.mesh, kPoints, std::sqrt(area / kPoints), 42);
    std::vector<int32_t> order(kPoints);
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(),
                     [&](int32_t a, int32_t b) { return sc.points.triangle[a] < sc.points.triangle[b]; });
    for (int32_t i : order)
      sc.sorted.add(sc.points.triangle[i], sc.points.barycentric[2 * size_t(i)],
                    sc.points.barycentric[2 * size_t(i) + 1], sc.points.radius[i]);
    return sc;
  }();
  return s;
}

// Args: K, threads, point order (0 random, 1 grouped by triangle).
void BM_RoundRings700k(benchmark::State& state) {
  const Scene& s = scene();
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, size_t(state.range(1)));
  texsynth::RoundRingsParams params;
  params.rings = int(state.range(0));
  const ring_fixtures::Points& points = state.range(2) ? s.sorted : s.points;
  double invalid = 0, bytes = 0;
  for (auto _ : state) {
    texsynth::RoundRings rr = texsynth::build_round_rings(s.mesh.input(), points.input(), params);
    invalid = rr.invalid_fraction();
    bytes = double(rr.points.size() * sizeof(texsynth::RingPoint) + (rr.normal.size() + rr.tangent.size()) * sizeof(float));
    benchmark::DoNotOptimize(rr.points.data());
  }
  state.counters["points/s"] = benchmark::Counter(double(kPoints) * double(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["bytes/point"] = bytes / kPoints;
  state.counters["invalid"] = invalid;
  state.counters["triangles"] = s.mesh.num_triangles();
  state.counters["r"] = s.points.radius[0];
}
BENCHMARK(BM_RoundRings700k)
    ->ArgsProduct({{4, 2}, {1, 2}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(2)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
