// SPDX-License-Identifier: GPL-3.0-or-later
// RayCaster on a ~1M-face bumpy torus: BVH + grid build, single-ray casts (a brush dab), radius
// queries, and a brute-force single ray over all triangles as the baseline (same run).
#include <benchmark/benchmark.h>

#include <cmath>
#include <limits>
#include <memory>

#include "texsynth/raycast/raycaster.hpp"
#include "../mesh_fixtures.hpp"

namespace {

using Torus = fixtures::TestMesh;

const Torus& torus() {
  static Torus t = [] {
    Torus m;
    const int segments = 1414, rings = 707;  // 999,698 quads
    const double pi = 3.14159265358979323846;
    for (int i = 0; i < segments; ++i)
      for (int j = 0; j < rings; ++j) {
        double u = 2 * pi * i / segments, v = 2 * pi * j / rings;
        double tube = 0.35 + 0.03 * std::sin(7 * u) * std::sin(5 * v);
        m.positions.insert(m.positions.end(), {float((1 + tube * std::cos(v)) * std::cos(u)),
                                               float((1 + tube * std::cos(v)) * std::sin(u)), float(tube * std::sin(v))});
      }
    for (int i = 0; i < segments; ++i)
      for (int j = 0; j < rings; ++j) {
        int i1 = (i + 1) % segments, j1 = (j + 1) % rings;
        m.poly_starts.push_back(int32_t(m.corner_verts.size()));
        m.poly_sizes.push_back(4);
        m.corner_verts.insert(m.corner_verts.end(), {i * rings + j, i1 * rings + j, i1 * rings + j1, i * rings + j1});
      }
    return m;
  }();
  return t;
}

const texsynth::RayCaster& caster() {
  static texsynth::RayCaster c(torus().input());
  return c;
}

void BM_BuildRayCaster1M(benchmark::State& state) {
  const Torus& t = torus();
  for (auto _ : state) {
    texsynth::RayCaster c(t.input());
    benchmark::DoNotOptimize(c.num_triangles());
  }
}
BENCHMARK(BM_BuildRayCaster1M)->Unit(benchmark::kMillisecond)->Iterations(3)->UseRealTime();

void BM_DabHitTest1M(benchmark::State& state) {  // one ray + radius 0.05 query, as per brush event
  const texsynth::RayCaster& c = caster();
  std::vector<int32_t> ids;
  std::vector<float> dist;
  float a = 0;
  for (auto _ : state) {
    const float o[3] = {std::cos(a), std::sin(a), 2.f}, d[3] = {0, 0, -1};
    auto hit = c.cast(o, d, 1);
    if (hit[0].face >= 0) {
      const float p[3] = {o[0], o[1], o[2] - hit[0].distance};
      c.vertices_within(p, 0.05f, ids, dist);
    }
    a += 0.01f;
    benchmark::DoNotOptimize(ids.data());
  }
}
BENCHMARK(BM_DabHitTest1M)->Unit(benchmark::kMicrosecond);

void BM_BruteForceRay1M(benchmark::State& state) {  // baseline: test every fan triangle
  const Torus& t = torus();
  for (auto _ : state) {
    const double o[3] = {1, 0, 2}, d[3] = {0, 0, -1};
    double best = std::numeric_limits<double>::infinity();
    auto P = [&](int32_t v, int a) { return double(t.positions[3 * size_t(v) + a]); };
    for (size_t p = 0; p < t.poly_starts.size(); ++p) {
      const int32_t* cv = &t.corner_verts[t.poly_starts[p]];
      for (int k = 1; k + 1 < t.poly_sizes[p]; ++k) {
        double e1[3], e2[3], s[3];
        for (int a = 0; a < 3; ++a) e1[a] = P(cv[k], a) - P(cv[0], a), e2[a] = P(cv[k + 1], a) - P(cv[0], a), s[a] = o[a] - P(cv[0], a);
        double h[3] = {d[1] * e2[2] - d[2] * e2[1], d[2] * e2[0] - d[0] * e2[2], d[0] * e2[1] - d[1] * e2[0]};
        double det = e1[0] * h[0] + e1[1] * h[1] + e1[2] * h[2];
        if (std::fabs(det) < 1e-15) continue;
        double u = (s[0] * h[0] + s[1] * h[1] + s[2] * h[2]) / det;
        double q[3] = {s[1] * e1[2] - s[2] * e1[1], s[2] * e1[0] - s[0] * e1[2], s[0] * e1[1] - s[1] * e1[0]};
        double v = (d[0] * q[0] + d[1] * q[1] + d[2] * q[2]) / det;
        double tt = (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) / det;
        if (u >= 0 && v >= 0 && u + v <= 1 && tt > 0 && tt < best) best = tt;
      }
    }
    benchmark::DoNotOptimize(best);
  }
}
BENCHMARK(BM_BruteForceRay1M)->Unit(benchmark::kMillisecond);

void BM_BatchCast1M(benchmark::State& state) {  // 64k rays at once (e.g. projecting a stroke batch)
  const texsynth::RayCaster& c = caster();
  const int n = 65536;
  std::vector<float> o(3 * n), d(3 * n);
  for (int i = 0; i < n; ++i) {
    float a = 6.2831853f * i / n;
    o[3 * i] = std::cos(a), o[3 * i + 1] = std::sin(a), o[3 * i + 2] = 2.f;
    d[3 * i] = 0, d[3 * i + 1] = 0, d[3 * i + 2] = -1;
  }
  for (auto _ : state) benchmark::DoNotOptimize(c.cast(o.data(), d.data(), n).data());
  state.SetItemsProcessed(state.iterations() * n);
}
BENCHMARK(BM_BatchCast1M)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
