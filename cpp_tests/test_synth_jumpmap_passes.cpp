// SPDX-License-Identifier: GPL-3.0-or-later
// The jump map's pass structure (validity boxes written per corner by the polygon pass and
// gathered per vertex, in the blend-weight output or a buffer of their own; the blend sets'
// vertex-mapping offsets stored in the blend-set output by that pass and completed by the corner
// pass; output pages pre-faulted by the order thread; parallel address copy and fallback-face
// count) against the previous passes
// (JumpSynthParams::baseline_passes), bit for bit, on meshes whose vertex and polygon orders are
// shuffled, at 1 and 2 threads, for every blend-set count and output layout.
#include <gtest/gtest.h>
#include <tbb/global_control.h>


#include <atomic>
#include <string>
#include <utility>
#include <vector>

#include "mesh_fixtures.hpp"
#include "texsynth/common/errors.hpp"
#include "texsynth/common/rng.hpp"
#include "texsynth/field/orientation_field.hpp"
#include "texsynth/synth/jumpmap_synth.hpp"

using fixtures::TestMesh;
using texsynth::JumpSynthParams;

namespace {

// Vertex indices permuted and polygons shuffled, each polygon's corner cycle kept (rotated by a
// random start): an order unrelated to the surface, as after some importers and subdivisions.
TestMesh shuffled(const TestMesh& t, uint64_t seed) {
  texsynth::Rng rng(seed);
  const int32_t nv = t.num_vertices(), np = int32_t(t.poly_starts.size());
  std::vector<int32_t> new_index(nv), poly_order(np);
  for (int32_t i = 0; i < nv; ++i) new_index[i] = i;
  for (int32_t i = 0; i < np; ++i) poly_order[i] = i;
  for (int32_t i = nv - 1; i > 0; --i) std::swap(new_index[i], new_index[rng.below(uint32_t(i + 1))]);
  for (int32_t i = np - 1; i > 0; --i) std::swap(poly_order[i], poly_order[rng.below(uint32_t(i + 1))]);
  TestMesh out;
  out.positions.resize(t.positions.size());
  for (int32_t v = 0; v < nv; ++v)
    for (int a = 0; a < 3; ++a) out.positions[3 * size_t(new_index[v]) + a] = t.positions[3 * size_t(v) + a];
  for (int32_t p : poly_order) {
    const int32_t n = t.poly_sizes[p], start = int32_t(rng.below(uint32_t(n)));
    std::vector<int32_t> verts;
    for (int32_t i = 0; i < n; ++i) verts.push_back(new_index[t.corner_verts[t.poly_starts[p] + (start + i) % n]]);
    out.add_poly(verts);
  }
  return out;
}

// Jittered quads, triangles of a noisy sphere and a strip of hexagons (n-gons: n > 4 sets).
TestMesh mixed_mesh() {
  TestMesh m = fixtures::grid(70, 60, 1.0, false, 0.35, 9);
  auto append = [&m](const TestMesh& part, double dx) {
    const int32_t offset = m.num_vertices();
    for (int32_t v = 0; v < part.num_vertices(); ++v)
      m.add_vertex(part.positions[3 * v] + dx, part.positions[3 * v + 1], part.positions[3 * v + 2]);
    for (size_t p = 0; p < part.poly_starts.size(); ++p) {
      std::vector<int32_t> poly;
      for (int32_t i = 0; i < part.poly_sizes[p]; ++i) poly.push_back(part.corner_verts[part.poly_starts[p] + i] + offset);
      m.add_poly(poly);
    }
  };
  append(fixtures::uv_sphere(30, 50, 8.0, 0.05), 100.0);
  TestMesh hexagons;  // two rows of vertices, each hexagon 0-1-2 on the bottom, 2'-1'-0' on top
  for (int row = 0; row < 2; ++row)
    for (int i = 0; i <= 40; ++i) hexagons.add_vertex(i * 0.6, row * 1.3 + ((i % 2) ? 0.2 : 0.0), 0.1 * (i % 3));
  for (int h = 0; h < 20; ++h) {
    const int32_t b = 2 * h, t = 41 + 2 * h;
    hexagons.add_poly({b, b + 1, b + 2, t + 2, t + 1, t});
  }
  append(hexagons, -50.0);
  return m;
}

struct Outputs {
  texsynth::JumpSynthResult result;
  std::vector<float> base, blend, weights;  // caller buffers (view runs)
};

struct Case {
  const char* name;
  TestMesh mesh;
  bool blend;
  bool view;    // caller-owned buffers, garbage-filled (else the vector outputs)
  bool packed;  // view only: blend sets in pairs (the add-on's layout)
  double scale;
  int sample;  // sample side (texels)
};

Outputs synthesize(const Case& c, const texsynth::Preprocessed& pre, int threads, bool baseline) {
  tbb::global_control control(tbb::global_control::max_allowed_parallelism, threads);
  const texsynth::Mesh m = texsynth::build_mesh(c.mesh.input());
  const std::vector<float> up = texsynth::compute_orientation_field(m, texsynth::FieldParams());
  JumpSynthParams p;
  p.scale = c.scale;
  p.seed = 7;
  p.blend = c.blend;
  p.allow_oversized = true;
  p.baseline_passes = baseline;
  Outputs run;
  if (!c.view) {
    run.result = texsynth::synthesize_jumpmap(pre, m, up.data(), p);
    return run;
  }
  const int32_t S = texsynth::jumpmap_blend_sets(m.poly_sizes, m.num_polys, c.blend);
  const size_t L = size_t(m.num_corners);
  run.base.assign(2 * L, -7.f);
  run.blend.assign(c.packed ? size_t((S + 1) / 2) * L * 4 : size_t(S) * L * 2, -7.f);
  run.weights.assign(L * size_t(S), -7.f);
  texsynth::CornerMapsView view{m.num_corners, S, run.base.data(), run.blend.data(), run.weights.data()};
  view.packed_pairs = c.packed;
  run.result = texsynth::synthesize_jumpmap(pre, m, up.data(), p, view);
  return run;
}

void expect_same(const Outputs& a, const Outputs& b, const std::string& what) {
  SCOPED_TRACE(what);
  EXPECT_EQ(a.result.maps.base_uv, b.result.maps.base_uv);
  EXPECT_EQ(a.result.maps.blend_uv, b.result.maps.blend_uv);
  EXPECT_EQ(a.result.maps.blend_weights, b.result.maps.blend_weights);
  EXPECT_EQ(a.base, b.base);
  EXPECT_EQ(a.blend, b.blend);
  EXPECT_EQ(a.weights, b.weights);
  EXPECT_EQ(a.result.vertex_address, b.result.vertex_address);
  EXPECT_EQ(a.result.stats.jumps, b.result.stats.jumps);
  EXPECT_EQ(a.result.stats.fallback_vertices, b.result.stats.fallback_vertices);
  EXPECT_EQ(a.result.stats.fallback_faces, b.result.stats.fallback_faces);
  EXPECT_EQ(a.result.stats.oversized_faces, b.result.stats.oversized_faces);
  EXPECT_EQ(a.result.stats.max_oversize_ratio, b.result.stats.max_oversize_ratio);
}

}  // namespace

TEST(SynthJumpmapPasses, ShuffledMeshesGiveTheBaselineOutputsAtOneAndTwoThreads) {
  const TestMesh mixed = shuffled(mixed_mesh(), 3);
  const TestMesh sphere = shuffled(fixtures::uv_sphere(60, 90, 1.0, 0.05), 4);  // all triangles: S = 3
  const std::vector<Case> cases = {
      {"mixed, S=4, vectors", mixed, true, false, false, 6.0, 256},
      {"mixed, S=4, packed view (boxes in the weights)", mixed, true, true, true, 6.0, 256},
      {"sphere, S=3, view (boxes in their own buffer)", sphere, true, true, false, 40.0, 128},
      {"sphere, S=3, packed view", sphere, true, true, true, 40.0, 128},
      {"mixed, S=1, vectors (boxes in their own buffer)", mixed, false, false, false, 6.0, 256},
      {"mixed, S=1, packed view (no sets stored)", mixed, false, true, true, 6.0, 256},
      // A small sample: many vertices have no valid candidate (fallback faces counted in parallel).
      {"mixed, S=4, small sample", mixed, true, true, true, 9.0, 24},
  };
  for (const Case& c : cases) {
    const auto pre = fixtures::planted(c.sample, c.sample, 4, 0.9f, false, c.sample / 50);
    const Outputs reference = synthesize(c, pre, 1, true);
    EXPECT_GT(reference.result.stats.vertices, 0);
    if (std::string(c.name).find("small sample") != std::string::npos)
      EXPECT_GT(reference.result.stats.fallback_faces, 0) << "the case must exercise the fallback-face count";
    if (c.view) {  // every element of the garbage-filled buffers was overwritten
      for (const std::vector<float>* buffer : {&reference.base, &reference.blend, &reference.weights})
        for (float x : *buffer) ASSERT_NE(x, -7.f) << c.name;
    }
    for (int threads : {1, 2})
      for (bool baseline : {true, false}) {
        if (threads == 1 && baseline) continue;
        expect_same(reference, synthesize(c, pre, threads, baseline),
                    std::string(c.name) + (baseline ? ", baseline" : ", new") + ", threads " + std::to_string(threads));
      }
  }
}

TEST(SynthJumpmapPasses, NewPassesStillStopWhenCancelled) {
  const TestMesh t = shuffled(fixtures::grid(60, 60, 1.0, false, 0.3), 5);
  const auto pre = fixtures::planted(64, 64, 4, 0.9f, false, 1);
  const texsynth::Mesh m = texsynth::build_mesh(t.input());
  const std::vector<float> up = texsynth::compute_orientation_field(m, texsynth::FieldParams());
  std::atomic<bool> raised{true};
  JumpSynthParams p;
  p.scale = 4.0;
  p.cancel = &raised;
  EXPECT_THROW(texsynth::synthesize_jumpmap(pre, m, up.data(), p), texsynth::Cancelled);
}
