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
using fixtures::mixed_mesh;
using fixtures::shuffled;
using texsynth::JumpSynthParams;

namespace {


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
