// SPDX-License-Identifier: GPL-3.0-or-later
// The parallel stages (vertex -> corner tables, one-rings, vertex normals, face measurement and
// reach boxes, corner output) against serial reference computations, bit for bit, at 1 and 2
// threads, and the caller-owned output buffers against the vector outputs.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "mesh_fixtures.hpp"
#include "texsynth/field/orientation_field.hpp"
#include "texsynth/mesh/vec_math.hpp"
#include "texsynth/synth/jumpmap_synth.hpp"

using fixtures::TestMesh;
using texsynth::JumpSynthParams;

namespace {

texsynth::Mesh build_with_threads(const TestMesh& t, int threads) {
  tbb::global_control c(tbb::global_control::max_allowed_parallelism, threads);
  return texsynth::build_mesh(t.input());
}

// A mixed mesh large enough for many parallel chunks: a jittered triangle grid, a quad grid and a
// noisy sphere side by side, plus a polygon repeating a vertex.
TestMesh big_mixed_mesh() {
  TestMesh m = fixtures::grid(120, 90, 1.0, true, 0.4, 7);
  for (const TestMesh& part : {fixtures::grid(80, 70, 0.5, false, 0.3, 8), fixtures::uv_sphere(60, 90, 3.0, 0.05)}) {
    const int32_t offset = m.num_vertices();
    for (int32_t v = 0; v < part.num_vertices(); ++v)
      m.add_vertex(part.positions[3 * v] + 200.0, part.positions[3 * v + 1], part.positions[3 * v + 2]);
    for (size_t p = 0; p < part.poly_starts.size(); ++p) {
      std::vector<int32_t> poly;
      for (int32_t i = 0; i < part.poly_sizes[p]; ++i) poly.push_back(part.corner_verts[part.poly_starts[p] + i] + offset);
      m.add_poly(poly);
    }
  }
  m.add_poly({0, 1, 1, 122});  // repeated vertex: its corners and Newell vector count twice
  return m;
}

}  // namespace

TEST(SynthParallel, VertexCornerTablesMatchSerialCountingSort) {
  const TestMesh t = big_mixed_mesh();
  const texsynth::Mesh m = build_with_threads(t, 2);
  std::vector<std::vector<int32_t>> expected(t.num_vertices());
  std::vector<int32_t> expected_poly;
  for (size_t p = 0; p < t.poly_starts.size(); ++p)
    for (int32_t i = 0; i < t.poly_sizes[p]; ++i) {
      expected[t.corner_verts[t.poly_starts[p] + i]].push_back(t.poly_starts[p] + i);
      expected_poly.push_back(int32_t(p));
    }
  EXPECT_EQ(m.corner_poly, expected_poly);
  ASSERT_EQ(m.vertex_corner_start.size(), size_t(t.num_vertices()) + 1);
  for (int32_t v = 0; v < t.num_vertices(); ++v)
    EXPECT_EQ(std::vector<int32_t>(m.vertex_corners.begin() + m.vertex_corner_start[v],
                                   m.vertex_corners.begin() + m.vertex_corner_start[v + 1]),
              expected[v])
        << "vertex " << v;
}

TEST(SynthParallel, VertexNormalsEqualSerialScatterSumBitForBit) {
  const TestMesh t = big_mixed_mesh();
  // The pre-parallel algorithm: scatter-add each polygon's Newell vector in polygon order.
  std::vector<double> acc(size_t(t.num_vertices()) * 3, 0.0);
  for (size_t p = 0; p < t.poly_starts.size(); ++p) {
    const int32_t* cv = t.corner_verts.data() + t.poly_starts[p];
    const texsynth::V3 nf = texsynth::newell_vector(t.positions.data(), cv, t.poly_sizes[p]);
    for (int32_t i = 0; i < t.poly_sizes[p]; ++i)
      acc[3 * cv[i]] += nf.x, acc[3 * cv[i] + 1] += nf.y, acc[3 * cv[i] + 2] += nf.z;
  }
  for (int threads : {1, 2}) {
    const texsynth::Mesh m = build_with_threads(t, threads);
    for (int32_t v = 0; v < t.num_vertices(); ++v) {
      const double len = std::sqrt(acc[3 * v] * acc[3 * v] + acc[3 * v + 1] * acc[3 * v + 1] + acc[3 * v + 2] * acc[3 * v + 2]);
      ASSERT_GT(len, 0.0) << "vertex " << v;
      for (int k = 0; k < 3; ++k)
        ASSERT_EQ(m.normals[3 * v + k], float(acc[3 * v + k] * (1.0 / len))) << "vertex " << v << " threads " << threads;
    }
  }
}

TEST(SynthParallel, MeshIsIdenticalAtOneAndTwoThreads) {
  const TestMesh t = big_mixed_mesh();
  const texsynth::Mesh one = build_with_threads(t, 1), two = build_with_threads(t, 2);
  EXPECT_EQ(one.neighbour_start, two.neighbour_start);
  EXPECT_EQ(one.neighbours, two.neighbours);
  EXPECT_EQ(one.normals, two.normals);
  EXPECT_EQ(one.component, two.component);
  EXPECT_EQ(one.vertex_corners, two.vertex_corners);
}

TEST(SynthParallel, SynthesisOnLargeMixedMeshIsIdenticalAtOneAndTwoThreads) {
  const TestMesh t = big_mixed_mesh();
  const auto pre = fixtures::planted(256, 256, 4, 0.9f, false, 5);
  JumpSynthParams p;
  p.scale = 6.0;
  p.seed = 5;
  p.allow_oversized = true;  // the 200-unit-wide mesh does not fit: exercises oversized statistics
  auto run = [&](int threads) {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, threads);
    const texsynth::Mesh m = texsynth::build_mesh(t.input());
    const std::vector<float> up = texsynth::compute_orientation_field(m, texsynth::FieldParams());
    return texsynth::synthesize_jumpmap(pre, m, up.data(), p);
  };
  const auto one = run(1), two = run(2);
  EXPECT_EQ(one.maps.base_uv, two.maps.base_uv);
  EXPECT_EQ(one.maps.blend_uv, two.maps.blend_uv);
  EXPECT_EQ(one.maps.blend_weights, two.maps.blend_weights);
  EXPECT_EQ(one.vertex_address, two.vertex_address);
  EXPECT_EQ(one.stats.jumps, two.stats.jumps);
  EXPECT_EQ(one.stats.oversized_faces, two.stats.oversized_faces);
  EXPECT_EQ(one.stats.max_oversize_ratio, two.stats.max_oversize_ratio);
  EXPECT_EQ(one.stats.fallback_vertices, two.stats.fallback_vertices);
}

TEST(SynthParallel, CallerBuffersGetExactlyTheVectorOutputs) {
  const TestMesh t = fixtures::uv_sphere(30, 40, 1.0, 0.05);  // all triangles: S = 3
  const auto pre = fixtures::planted(100, 100, 4, 0.9f, false, 5);
  const texsynth::Mesh m = texsynth::build_mesh(t.input());
  const std::vector<float> up = texsynth::compute_orientation_field(m, texsynth::FieldParams());
  JumpSynthParams p;
  p.scale = 20.0;
  p.seed = 3;
  const auto reference = texsynth::synthesize_jumpmap(pre, m, up.data(), p);
  ASSERT_EQ(texsynth::jumpmap_blend_sets(m.poly_sizes, m.num_polys, true), 3);
  const size_t L = size_t(m.num_corners);
  // Garbage-filled buffers: every element must be overwritten (one-hot zeros included).
  std::vector<float> base(L * 2, -7.f), blend(3 * L * 2, -7.f), weights(L * 3, -7.f);
  const auto r = texsynth::synthesize_jumpmap(pre, m, up.data(), p,
                                              texsynth::CornerMapsView{m.num_corners, 3, base.data(), blend.data(), weights.data()});
  EXPECT_TRUE(r.maps.base_uv.empty());
  EXPECT_EQ(base, reference.maps.base_uv);
  EXPECT_EQ(blend, reference.maps.blend_uv);
  EXPECT_EQ(weights, reference.maps.blend_weights);
  EXPECT_EQ(r.vertex_address, reference.vertex_address);
  auto error = [&](texsynth::CornerMapsView view) {
    try {
      texsynth::synthesize_jumpmap(pre, m, up.data(), p, view);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(error({m.num_corners, 4, base.data(), blend.data(), weights.data()}).find("expected"), std::string::npos);
  EXPECT_NE(error({m.num_corners - 1, 3, base.data(), blend.data(), weights.data()}).find("expected"), std::string::npos);
  EXPECT_NE(error({m.num_corners, 3, base.data(), nullptr, weights.data()}).find("missing"), std::string::npos);
  EXPECT_EQ(texsynth::jumpmap_blend_sets(m.poly_sizes, m.num_polys, false), 1);
}

TEST(SynthParallel, HugeFaceErrorNamesTheLowestSuchFace) {
  TestMesh t = fixtures::grid(300, 40, 1.0, false);  // 12000 quads: several parallel chunks
  // Faces 9000 and 11000 are stretched far beyond 1e9 texels at this scale; 9000 must be named.
  for (int32_t face : {11000, 9000}) {
    const int32_t v = t.corner_verts[t.poly_starts[face] + 2];
    t.positions[3 * v] += 1e12;
  }
  const auto pre = fixtures::planted(16, 16, 1, 1.f, false);
  const texsynth::Mesh m = texsynth::build_mesh(t.input());
  const std::vector<float> up = texsynth::compute_orientation_field(m, texsynth::FieldParams());
  JumpSynthParams p;
  p.scale = 1.0;
  p.allow_oversized = true;
  try {
    texsynth::synthesize_jumpmap(pre, m, up.data(), p);
    FAIL() << "expected invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("face 9000 span"), std::string::npos) << e.what();
  }
}
