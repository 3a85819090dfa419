// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <set>
#include <thread>
#include <stdexcept>
#include <string>

#include "blend_checks.hpp"
#include "mesh_fixtures.hpp"
#include "texsynth/field/orientation_field.hpp"
#include "texsynth/synth/jumpmap_synth.hpp"

using fixtures::TestMesh;
using texsynth::JumpSynthParams;
using texsynth::JumpSynthResult;

namespace {

struct SynthRun {
  TestMesh t;
  texsynth::Mesh mesh;
  std::vector<float> field;
  JumpSynthResult r;
};

SynthRun run(const TestMesh& t, const texsynth::Preprocessed& pre, JumpSynthParams p,
        texsynth::FieldParams fp = texsynth::FieldParams()) {
  SynthRun out;
  out.t = t;
  out.mesh = texsynth::build_mesh(out.t.input());
  out.field = texsynth::compute_orientation_field(out.mesh, fp);
  out.r = texsynth::synthesize_jumpmap(pre, out.mesh, out.field.data(), p);
  return out;
}

const float* uv_of(const JumpSynthResult& r, int set, int32_t corner) {
  return set < 0 ? &r.maps.base_uv[2 * size_t(corner)]
                 : &r.maps.blend_uv[(size_t(set) * r.maps.num_corners + corner) * 2];
}

// Every polygon, in every UV set, must be a similarity: scale `scale` texels per unit, not mirrored,
// and (when up != null) texture "up" along the given 3D direction projected onto the face.
// Uses only positions and output UVs. Polygons: fan triangles (0, i, i+1) must all give the same map.
// set_tol (>= 0) replaces tol for the blend sets: on curved meshes they are projections on their
// vertex's tangent plane, off a similarity by 1 - cos(angle between vertex and face normals).
// last_set = -1 checks the base mapping only.
void expect_similarities(const SynthRun& run, const texsynth::Preprocessed& pre, double scale, const double* up,
                         double base_tol = 2e-3, const std::vector<double>* per_vertex_scale = nullptr,
                         double set_tol = -1, int last_set = 1000) {
  const auto& t = run.t;
  const auto& r = run.r;
  int checked = 0;
  for (int set = -1; set < std::min(r.maps.num_blend_sets, last_set + 1); ++set)
    for (size_t p = 0; p < t.poly_starts.size(); ++p) {
      const double tol = set >= 0 && set_tol >= 0 ? set_tol : base_tol;
      const int32_t first = t.poly_starts[p], n = t.poly_sizes[p];
      fixtures::FaceMap ref;
      bool have_ref = false;
      double expected = scale;
      if (per_vertex_scale) {
        double sum = 0;
        for (int i = 0; i < n; ++i) sum += (*per_vertex_scale)[t.corner_verts[first + i]];
        expected = scale * sum / n;
      }
      for (int i = 1; i + 1 < n; ++i) {
        std::array<std::array<double, 3>, 3> pos;
        std::array<std::array<double, 2>, 3> uv;
        int corners[3] = {first, first + i, first + i + 1};
        for (int k = 0; k < 3; ++k) {
          int32_t v = t.corner_verts[corners[k]];
          pos[k] = {t.positions[3 * v], t.positions[3 * v + 1], t.positions[3 * v + 2]};
          const float* q = uv_of(r, set, corners[k]);
          uv[k] = {q[0], q[1]};
        }
        fixtures::FaceMap f;
        if (!fixtures::face_map(pos, uv, pre.width, pre.height, f)) continue;
        auto sv = fixtures::singular_values(f.J);
        ASSERT_NEAR(sv[0], expected, tol * expected) << "poly " << p << " set " << set;
        ASSERT_NEAR(sv[1], expected, tol * expected) << "poly " << p << " set " << set;
        double det = f.J[0][0] * f.J[1][1] - f.J[0][1] * f.J[1][0];
        ASSERT_LT(det, 0) << "mirrored mapping (texel y points down, so det < 0 is unmirrored), poly " << p;
        if (up) {
          auto d = fixtures::texture_up_direction(f);
          // expected: up projected onto the face plane
          double nrm[3] = {f.e1[1] * f.e2[2] - f.e1[2] * f.e2[1], f.e1[2] * f.e2[0] - f.e1[0] * f.e2[2],
                           f.e1[0] * f.e2[1] - f.e1[1] * f.e2[0]};
          double un = up[0] * nrm[0] + up[1] * nrm[1] + up[2] * nrm[2];
          double e[3] = {up[0] - un * nrm[0], up[1] - un * nrm[1], up[2] - un * nrm[2]};
          double le = std::sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
          ASSERT_GT((d[0] * e[0] + d[1] * e[1] + d[2] * e[2]) / le, 1 - 1e-5) << "poly " << p;
        }
        if (have_ref) {  // the fan triangles of one polygon share one map: predict corner i+1 with ref
          int32_t v0 = t.corner_verts[first], v2 = t.corner_verts[first + i + 1];
          double d3[3] = {t.positions[3 * v2] - t.positions[3 * v0], t.positions[3 * v2 + 1] - t.positions[3 * v0 + 1],
                          t.positions[3 * v2 + 2] - t.positions[3 * v0 + 2]};
          double l0 = d3[0] * ref.e1[0] + d3[1] * ref.e1[1] + d3[2] * ref.e1[2];
          double l1 = d3[0] * ref.e2[0] + d3[1] * ref.e2[1] + d3[2] * ref.e2[2];
          const float* q0 = uv_of(r, set, first);
          const float* q2 = uv_of(r, set, first + i + 1);
          double px = q0[0] * pre.width + ref.J[0][0] * l0 + ref.J[0][1] * l1;
          double py = (1 - q0[1]) * pre.height + ref.J[1][0] * l0 + ref.J[1][1] * l1;
          ASSERT_NEAR(q2[0] * pre.width, px, tol * expected) << "poly " << p << " corner " << i + 1;
          ASSERT_NEAR((1 - q2[1]) * pre.height, py, tol * expected) << "poly " << p << " corner " << i + 1;
        }
        if (!have_ref) ref = f;
        have_ref = true;
        ++checked;
      }
    }
  EXPECT_GE(checked, int(t.poly_starts.size()));
}

void expect_c0_across_edges(const SynthRun& run) {
  EXPECT_GT(fixtures::expect_c0_across_edges(run.t, run.r.maps, run.r.maps.num_blend_sets),
            int(run.t.poly_starts.size()));
}

void expect_inside_sample(const JumpSynthResult& r) {
  for (float x : r.maps.base_uv) ASSERT_TRUE(x >= 0.f && x <= 1.f) << x;
  for (float x : r.maps.blend_uv) ASSERT_TRUE(x >= 0.f && x <= 1.f) << x;
}

// Set k's grown-from corner carries exactly its vertex's own address, and weights are one-hot.
void expect_blend_sets_consistent(const SynthRun& run, const texsynth::Preprocessed& pre) {
  const auto& t = run.t;
  const auto& r = run.r;
  const int S = r.maps.num_blend_sets;
  for (size_t p = 0; p < t.poly_starts.size(); ++p) {
    const int32_t first = t.poly_starts[p], n = t.poly_sizes[p];
    for (int k = 0; k < std::min(S, n); ++k) {
      int from = n <= S ? k : int((int64_t(k) * n + S - 1) / S);
      int32_t v = t.corner_verts[first + from];
      const float* uv = uv_of(r, k, first + from);
      ASSERT_NEAR(uv[0] * pre.width, r.vertex_address[2 * v], 1e-3) << "poly " << p << " set " << k;
      ASSERT_NEAR((1 - uv[1]) * pre.height, r.vertex_address[2 * v + 1], 1e-3) << "poly " << p << " set " << k;
      ASSERT_EQ(r.maps.blend_weights[size_t(first + from) * S + k], 1.f) << "grown-from corner must weigh its own set";
    }
    bool base_found = false;
    for (int i = 0; i < n; ++i) {
      float sum = 0;
      for (int k = 0; k < S; ++k) {
        float w = r.maps.blend_weights[size_t(first + i) * S + k];
        ASSERT_TRUE(w == 0.f || w == 1.f);
        sum += w;
      }
      ASSERT_EQ(sum, 1.f);
      int32_t v = t.corner_verts[first + i];
      const float* b = uv_of(r, -1, first + i);
      if (std::fabs(b[0] * pre.width - r.vertex_address[2 * v]) < 1e-3 &&
          std::fabs((1 - b[1]) * pre.height - r.vertex_address[2 * v + 1]) < 1e-3)
        base_found = true;
    }
    ASSERT_TRUE(base_found) << "base mapping of poly " << p << " must pass through one corner's own address";
  }
}

std::string error_of(const TestMesh& t, const texsynth::Preprocessed& pre, JumpSynthParams p) {
  try {
    run(t, pre, p);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(SynthJumpMap, JitteredFlatGridFacesAreExactSimilaritiesWithRequestedScaleAndRotation) {
  auto pre = fixtures::planted(128, 96, 4, 0.9f, false, 8);
  auto grid = fixtures::grid(30, 25, 0.1, true, 0.6);
  for (double angle : {0.0, 0.7, 2.5}) {
    texsynth::FieldParams fp;
    fp.axis = {float(std::sin(angle)), float(std::cos(angle)), 0.3f};
    const double up[3] = {std::sin(angle), std::cos(angle), 0.0};
    JumpSynthParams p;
    p.scale = 37.0;
    p.seed = 5;
    auto r = run(grid, pre, p, fp);
    EXPECT_EQ(r.r.maps.num_blend_sets, 3);
    expect_similarities(r, pre, 37.0, up);
    expect_inside_sample(r.r);
    expect_blend_sets_consistent(r, pre);
  }
}

TEST(SynthJumpMap, QuadGridUsesFourSetsAndStaysSimilar) {
  auto pre = fixtures::planted(64, 64, 2, 1.0f, false, 4);
  auto grid = fixtures::grid(20, 20, 0.25, false, 0.0);
  JumpSynthParams p;
  p.scale = 9.0;
  auto r = run(grid, pre, p);
  EXPECT_EQ(r.r.maps.num_blend_sets, 4);
  expect_similarities(r, pre, 9.0, nullptr);
  expect_inside_sample(r.r);
  expect_blend_sets_consistent(r, pre);
}

TEST(SynthJumpMap, CurvedMeshesAreSimilaritiesWithCorrectScale) {
  auto pre = fixtures::planted(200, 150, 4, 0.8f, false, 10);
  JumpSynthParams p;
  p.scale = 40.0;
  // Blend sets unfold edges into their vertex's tangent plane (exact lengths, C0 across edges): on
  // the smooth sphere they stay within 1 % of a similarity; on the rough one (faces tilted by up to
  // ~45 degrees from the vertex normals) only the base mapping is an exact similarity.
  const double set_tolerance[2] = {1e-2, -1};
  int mesh_index = 0;
  for (const TestMesh& t : {fixtures::uv_sphere(20, 30, 1.0), fixtures::uv_sphere(24, 36, 1.0, 0.08)}) {
    texsynth::FieldParams fp;
    fp.mode = texsynth::OrientationMode::Anchors;
    fp.anchor_vertices = {7};
    fp.anchor_directions = {{0.f, 0.f, 1.f}};
    fp.sources = {0};
    auto r = run(t, pre, p, fp);
    const bool smooth = mesh_index++ == 0;
    expect_similarities(r, pre, 40.0, nullptr, 2e-3, nullptr, set_tolerance[smooth ? 0 : 1], smooth ? 1000 : -1);
    expect_c0_across_edges(r);
    expect_inside_sample(r.r);
    expect_blend_sets_consistent(r, pre);
    EXPECT_EQ(r.r.stats.fallback_vertices, 0);
    EXPECT_EQ(r.r.stats.fallback_faces, 0);
  }
}

TEST(SynthJumpMap, ScaleMultiplierScalesEachFace) {
  auto pre = fixtures::planted(128, 128, 2, 1.0f, false, 8);
  auto grid = fixtures::grid(12, 12, 0.1, true, 0.5);
  std::vector<double> mult(grid.num_vertices());
  std::vector<float> multf(grid.num_vertices());
  for (int v = 0; v < grid.num_vertices(); ++v) mult[v] = multf[v] = 1.0f + 0.25f * float(v % 5);
  JumpSynthParams p;
  p.scale = 20.0;
  p.scale_multiplier = multf.data();
  auto r = run(grid, pre, p);
  // The base mapping scales by the polygon's mean multiplier; each blend set by its own vertex's.
  expect_similarities(r, pre, 20.0, nullptr, 2e-3, &mult, -1, -1);
  expect_c0_across_edges(r);
}

TEST(SynthJumpMap, MeasuredJumpRateMatchesRequested) {
  // Quad grid with unit-texel edges: every continuation has |offset| = 1, so with all jumps valid
  // P(jump) = 1 / (jump_rate + 1) exactly (jump weights sum to 1 per pixel, bilinear keeps the sum).
  auto pre = fixtures::planted(512, 512, 4, 1.0f, false, 128);
  auto grid = fixtures::grid(120, 120, 1.0, false);
  for (double rate : {5.0, 20.0}) {
    JumpSynthParams p;
    p.scale = 1.0;
    p.jump_rate = rate;
    p.border_ramp = 0.0;
    p.seed = 3;
    auto r = run(grid, pre, p);
    const double expected = (r.r.stats.vertices - 1) / (rate + 1.0);
    EXPECT_NEAR(double(r.r.stats.jumps), expected, 0.08 * expected) << "rate " << rate;
    EXPECT_EQ(r.r.stats.fallback_vertices, 0);
  }
}

TEST(SynthJumpMap, RejectionDrawMatchesExactFilteredTable) {
  // Half of every pixel's jump weight points at column 0, where most one-rings would leave the
  // sample. The fast rejection draw must reproduce the exact filtered table's statistics
  // (max_rejection_draws = 0 builds the table for every vertex, the paper's direct method),
  // and both must differ clearly from what an unfiltered draw would give, 1 / (rate + 1).
  auto pre = fixtures::planted(512, 512, 4, 1.0f, false, 128);
  for (size_t i = 0; i < pre.jump_map.targets.size(); i += 2) pre.jump_map.targets[i] -= pre.jump_map.targets[i] % 512;
  auto grid = fixtures::grid(150, 150, 1.0, false);
  const double rate = 5.0;
  JumpSynthParams p;
  p.scale = 1.0;
  p.jump_rate = rate;
  p.border_ramp = 0.0;
  auto fast = run(grid, pre, p);
  p.max_rejection_draws = 0;
  auto exact = run(grid, pre, p);
  const double n = double(fast.r.stats.vertices - 1);
  const double jf = double(fast.r.stats.jumps), je = double(exact.r.stats.jumps);
  EXPECT_NEAR(jf, je, 4 * std::sqrt(je) + 1) << "fast " << jf << " exact " << je;
  std::printf("jumps: fast %.0f exact %.0f unfiltered-expectation %.0f of %.0f\n", jf, je, n / (rate + 1), n);
  EXPECT_LT(je, 0.8 * n / (rate + 1));
  EXPECT_GT(je, 0.9 * n * 0.5 / (rate + 0.5));  // at least the always-valid half is drawn
  expect_inside_sample(fast.r);
  expect_inside_sample(exact.r);
}

TEST(SynthJumpMap, NoJumpsForcesFallbacksButEverythingStaysInside) {
  auto pre = fixtures::planted(32, 32, 0, 0.f, false);
  auto grid = fixtures::grid(60, 60, 1.0, true, 0.3);
  JumpSynthParams p;
  p.scale = 1.5;
  auto r = run(grid, pre, p);
  EXPECT_EQ(r.r.stats.jumps, 0);
  EXPECT_GT(r.r.stats.fallback_vertices, 0);
  // Faces touching a fallback vertex: a triangle holds at most 3 of them, and no vertex of this
  // grid is on more than 6 triangles.
  EXPECT_GE(r.r.stats.fallback_faces, r.r.stats.fallback_vertices / 3);
  EXPECT_LE(r.r.stats.fallback_faces, 6 * r.r.stats.fallback_vertices);
  expect_inside_sample(r.r);
  expect_similarities(r, pre, 1.5, nullptr);
}

TEST(SynthJumpMap, TileableSamplesWrapAddresses) {
  auto pre = fixtures::planted(16, 16, 2, 0.5f, true);
  auto grid = fixtures::grid(40, 40, 1.0, true, 0.3);
  JumpSynthParams p;
  p.scale = 1.0;
  auto r = run(grid, pre, p);
  for (int32_t v = 0; v < r.mesh.num_vertices; ++v) {
    ASSERT_GE(r.r.vertex_address[2 * v], 0.f);
    ASSERT_LT(r.r.vertex_address[2 * v], 16.f);
    ASSERT_GE(r.r.vertex_address[2 * v + 1], 0.f);
    ASSERT_LT(r.r.vertex_address[2 * v + 1], 16.f);
  }
  EXPECT_EQ(r.r.stats.fallback_vertices, 0);
  expect_similarities(r, pre, 1.0, nullptr);
}

TEST(SynthJumpMap, DeterministicAcrossRunsAndThreadCounts) {
  auto pre = fixtures::planted(100, 100, 4, 0.9f, false, 5);
  auto t = fixtures::uv_sphere(60, 80, 1.0, 0.05);
  JumpSynthParams p;
  p.scale = 30.0;
  p.seed = 99;
  auto same = [](const JumpSynthResult& a, const JumpSynthResult& b) {
    return a.maps.base_uv == b.maps.base_uv && a.maps.blend_uv == b.maps.blend_uv &&
           a.maps.blend_weights == b.maps.blend_weights && a.stats.jumps == b.stats.jumps;
  };
  SynthRun one, two, again;
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
    one = run(t, pre, p);
  }
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
    two = run(t, pre, p);
    again = run(t, pre, p);
  }
  EXPECT_TRUE(same(one.r, two.r));
  EXPECT_TRUE(same(two.r, again.r));
  p.seed = 100;
  EXPECT_FALSE(same(one.r, run(t, pre, p).r));
}

TEST(SynthJumpMap, OversizedFacesAreReportedWithCounts) {
  auto pre = fixtures::planted(16, 16, 1, 1.f, false);
  TestMesh t = fixtures::grid(4, 1, 1.0, false);  // 4 unit quads
  JumpSynthParams p;
  p.scale = 20.0;  // each unit quad spans 20 texels > 16
  std::string msg = error_of(t, pre, p);
  EXPECT_NE(msg.find("of 4 faces are larger than the 16x16 sample"), std::string::npos) << msg;
  p.allow_oversized = true;
  auto r = run(t, pre, p);
  EXPECT_EQ(r.r.stats.oversized_faces, 4);
  EXPECT_GT(r.r.stats.max_oversize_ratio, 1.2);
  expect_inside_sample(r.r);
  // A scale where the faces fit exactly 0.5 of the sample: no report.
  p.scale = 8.0;
  p.allow_oversized = false;
  auto ok = run(fixtures::grid(4, 1, 1.0, false), pre, p);
  EXPECT_EQ(ok.r.stats.oversized_faces, 0);
  EXPECT_NEAR(ok.r.stats.max_oversize_ratio, 0.5, 1e-6);
}

TEST(SynthJumpMap, BadParametersAndPreprocessedAreRejected) {
  auto pre = fixtures::planted(16, 16, 2, 1.f, false);
  auto t = fixtures::grid(3, 3, 0.1, true);
  JumpSynthParams p;
  p.scale = 10;
  EXPECT_EQ(error_of(t, pre, p), "");
  JumpSynthParams q = p;
  q.scale = 0;
  EXPECT_NE(error_of(t, pre, q).find("scale"), std::string::npos);
  q.scale = NAN;
  EXPECT_NE(error_of(t, pre, q).find("scale"), std::string::npos);
  q = p;
  q.jump_rate = -1;
  EXPECT_NE(error_of(t, pre, q).find("jump_rate"), std::string::npos);
  std::vector<float> mult(t.num_vertices(), 1.f);
  mult[3] = 0.f;
  q = p;
  q.scale_multiplier = mult.data();
  EXPECT_NE(error_of(t, pre, q).find("scale_multiplier of vertex 3"), std::string::npos);
  auto bad = pre;
  bad.jump_map.targets[5] = 16 * 16;
  EXPECT_NE(error_of(t, bad, p).find("entry 5"), std::string::npos) << error_of(t, bad, p);
  bad = pre;
  bad.jump_map.weights.pop_back();
  EXPECT_NE(error_of(t, bad, p).find("expected width*height*k"), std::string::npos);
  bad = pre;
  bad.width = 0;
  EXPECT_THROW(run(t, bad, p), std::invalid_argument);
  q = p;
  q.scale = 1e38;
  EXPECT_THROW(run(t, pre, q), std::invalid_argument);
  q.allow_oversized = true;
  EXPECT_NE(error_of(t, pre, q).find("scale"), std::string::npos);  // absurd: rejected even when allowed
  q.scale = 1e6;  // large but representable: clamped, finite, reported
  auto big = run(t, pre, q);
  EXPECT_EQ(big.r.stats.oversized_faces, 18);
  expect_inside_sample(big.r);
}

TEST(SynthJumpMap, DegenerateMeshesGiveFiniteValidResults) {
  auto pre = fixtures::planted(64, 64, 3, 1.f, false, 4);
  TestMesh t;
  int32_t a = t.add_vertex(0, 0, 0), b = t.add_vertex(1, 0, 0), c = t.add_vertex(2, 0, 0);
  t.add_poly({a, b, c});  // zero area
  t.add_poly({a, a, a});  // all corners one vertex
  int32_t d = t.add_vertex(0, 0, 0);
  t.add_poly({d, b, t.add_vertex(0, 1, 0)});
  for (int i = 0; i < 3; ++i) t.add_poly({a, b, t.add_vertex(0.5, std::cos(i), std::sin(i))});  // non-manifold fan
  t.add_vertex(9, 9, 9);                                                                        // loose
  std::vector<int32_t> ring;
  for (int i = 0; i < 20; ++i) ring.push_back(t.add_vertex(5 + std::cos(i * 0.314), std::sin(i * 0.314), 0));
  t.add_poly(ring);  // 20-gon
  JumpSynthParams p;
  p.scale = 10.0;
  auto r = run(t, pre, p);
  EXPECT_EQ(r.r.maps.num_blend_sets, 4);
  for (float x : r.r.maps.base_uv) ASSERT_TRUE(std::isfinite(x));
  for (float x : r.r.maps.blend_uv) ASSERT_TRUE(std::isfinite(x));
  expect_inside_sample(r.r);
  expect_blend_sets_consistent(r, pre);
  // n-gon weights form S contiguous runs
  const int32_t first = t.poly_starts.back();
  for (int i = 0; i < 20; ++i) EXPECT_EQ(r.r.maps.blend_weights[size_t(first + i) * 4 + (i * 4) / 20], 1.f);
  // empty mesh: valid empty result
  auto e = run(TestMesh(), pre, p);
  EXPECT_EQ(e.r.maps.num_corners, 0);
  EXPECT_TRUE(e.r.maps.base_uv.empty());
}

TEST(SynthJumpMap, BlendOffGivesOneSetEqualToBase) {
  auto pre = fixtures::planted(64, 64, 2, 1.f, false, 4);
  JumpSynthParams p;
  p.scale = 10.0;
  p.blend = false;
  auto r = run(fixtures::grid(5, 5, 0.2, false), pre, p);
  EXPECT_EQ(r.r.maps.num_blend_sets, 1);
  EXPECT_EQ(r.r.maps.blend_uv, r.r.maps.base_uv);
  for (float w : r.r.maps.blend_weights) EXPECT_EQ(w, 1.f);
}

// ---- vertex order (§4.1)

TEST(SynthOrder, IsAPermutationGrowingFromSeedsWithNearGreedyChoices) {
  TestMesh t = fixtures::uv_sphere(10, 14, 1.0, 0.1);
  auto g = fixtures::grid(6, 6, 1.0, true);
  int32_t off = t.num_vertices();
  for (size_t i = 0; i < g.positions.size(); i += 3) t.add_vertex(g.positions[i] + 5, g.positions[i + 1], 0);
  for (size_t p = 0; p < g.poly_starts.size(); ++p)
    t.add_poly({off + g.corner_verts[3 * p], off + g.corner_verts[3 * p + 1], off + g.corner_verts[3 * p + 2]});
  t.add_vertex(20, 20, 20);  // loose: not ordered
  auto m = texsynth::build_mesh(t.input());
  for (auto order_fn : {texsynth::region_growing_order, texsynth::region_growing_order_heap}) {
    auto o = order_fn(m, 7, nullptr);
    ASSERT_EQ(o.order.size(), size_t(m.num_vertices - 1));
    ASSERT_EQ(o.component_start.size(), 3u);
    std::set<int32_t> seen(o.order.begin(), o.order.end());
    ASSERT_EQ(seen.size(), o.order.size());
    std::vector<char> done(m.num_vertices, 0);
    for (size_t i = 0; i < o.order.size(); ++i) {
      int32_t v = o.order[i];
      bool component_start = i == size_t(o.component_start[0]) || i == size_t(o.component_start[1]);
      // brute force: best proportion among unsynthesized vertices touching the synthesized region
      double best = 0, mine = 0;
      for (int32_t w = 0; w < m.num_vertices; ++w) {
        if (done[w] || m.component[w] < 0) continue;
        int count = 0;
        for (int32_t k = m.neighbour_start[w]; k < m.neighbour_start[w + 1]; ++k) count += done[m.neighbours[k]];
        double prop = m.degree(w) ? double(count) / m.degree(w) : 0;
        best = std::max(best, prop);
        if (w == v) mine = prop;
      }
      if (!component_start) {
        ASSERT_GT(mine, 0.0) << "step " << i << " is not adjacent to the synthesized region";
        ASSERT_GE(mine, best - 1.0 / texsynth::kOrderLevels - 1e-12) << "step " << i;
      } else {
        ASSERT_EQ(mine, 0.0);
      }
      done[v] = 1;
    }
  }
  // seed choice depends on the seed
  EXPECT_NE(texsynth::region_growing_order(m, 1).order[0], texsynth::region_growing_order(m, 2).order[0]);
}

// The streamed order (read by the walk while it is built) is the batch order, entry for entry, as
// seen by a consumer on another thread that only reads entries `ready` says are final.
TEST(SynthOrder, StreamedOrderMatchesBatchOrderWhileBeingRead) {
  TestMesh t = fixtures::grid(300, 300, 1.0, false, 0.3);
  auto m = texsynth::build_mesh(t.input());
  const std::vector<int32_t> batch = texsynth::region_growing_order(m, 5).order;
  std::vector<int32_t> streamed(size_t(m.num_vertices), -1), consumed;
  std::vector<uint32_t> ordered_neighbours(size_t(m.num_vertices));
  std::atomic<int32_t> ready{0};
  std::atomic<bool> done{false};
  int32_t count = -1;
  std::thread producer([&] {
    count = texsynth::stream_region_growing_order(m, 5, streamed.data(), ordered_neighbours.data(), ready);
    done.store(true);
  });
  for (int32_t step = 0;;) {
    const bool finished = done.load();
    const int32_t available = ready.load();
    while (step < available) consumed.push_back(streamed[step++]);
    if (finished && step == ready.load()) break;
  }
  producer.join();
  EXPECT_EQ(count, int32_t(batch.size()));
  EXPECT_EQ(ready.load(), count);
  EXPECT_EQ(consumed, batch);
  // Neighbour flags against the positions in the batch order.
  std::vector<int32_t> position(size_t(m.num_vertices), -1);
  for (size_t i = 0; i < batch.size(); ++i) position[batch[i]] = int32_t(i);
  for (size_t i = 0; i < batch.size(); ++i)
    for (int32_t k = 0; k < m.degree(batch[i]); ++k)
      ASSERT_EQ((ordered_neighbours[i] >> k) & 1u, uint32_t(position[m.neighbours[m.neighbour_start[batch[i]] + k]] < int32_t(i)))
          << "step " << i << " neighbour " << k;
}

// Random small meshes with random corruptions: every call either throws std::invalid_argument or
// returns finite UVs inside the sample (run under TEXSYNTH_SANITIZE=ON to catch memory errors).
TEST(SynthJumpMap, RandomMalformedInputsNeverCrash) {
  auto pre = fixtures::planted(32, 24, 3, 0.9f, false, 2);
  texsynth::Rng rng(2024);
  int valid = 0, rejected = 0;
  for (int trial = 0; trial < 400; ++trial) {
    TestMesh t;
    const int nv = 1 + int(rng.below(12));
    for (int v = 0; v < nv; ++v) t.add_vertex(rng.uniform(), rng.uniform(), rng.below(4) == 0 ? 0.0 : rng.uniform());
    const int np = int(rng.below(8));
    for (int p = 0; p < np; ++p) {
      std::vector<int32_t> poly;
      const int n = 3 + int(rng.below(rng.below(3) == 0 ? 18 : 2));
      for (int i = 0; i < n; ++i) poly.push_back(int32_t(rng.below(uint32_t(nv))));
      t.add_poly(poly);
    }
    switch (rng.below(8)) {  // one corruption, or none
      case 0: if (!t.corner_verts.empty()) t.corner_verts[rng.below(uint32_t(t.corner_verts.size()))] = int32_t(nv + rng.below(5)); break;
      case 1: if (!t.poly_sizes.empty()) t.poly_sizes[rng.below(uint32_t(t.poly_sizes.size()))] = int32_t(rng.below(3)); break;
      case 2: if (!t.poly_starts.empty()) t.poly_starts[rng.below(uint32_t(t.poly_starts.size()))] += 1; break;
      case 3: t.positions[rng.below(uint32_t(t.positions.size()))] = rng.below(2) ? NAN : INFINITY; break;
      case 4: if (!t.corner_verts.empty()) t.corner_verts.pop_back(); break;
      default: break;
    }
    texsynth::FieldParams fp;
    if (rng.below(2)) {
      fp.mode = texsynth::OrientationMode::Anchors;
      fp.sources = {int32_t(rng.below(uint32_t(nv + 1)))};  // sometimes out of range
    }
    JumpSynthParams p;
    p.scale = 2.0 + 60.0 * rng.uniform();
    p.allow_oversized = rng.below(2) == 0;
    p.seed = trial;
    try {
      auto r = run(t, pre, p, fp);
      for (float x : r.r.maps.blend_uv) ASSERT_TRUE(std::isfinite(x) && x >= 0.f && x <= 1.f) << "trial " << trial;
      for (float x : r.r.maps.base_uv) ASSERT_TRUE(std::isfinite(x) && x >= 0.f && x <= 1.f) << "trial " << trial;
      ++valid;
    } catch (const std::invalid_argument&) {
      ++rejected;
    }
  }
  EXPECT_GT(valid, 50);
  EXPECT_GT(rejected, 50);
}

// The add-on asks for the sets in RGBA pairs (CornerMapsView::packed_pairs); same values as set-major,
// zeros in the unused half when S is odd, and pack_set_pairs repacks set-major arrays identically.
TEST(SynthJumpMap, PackedPairsViewHoldsTheSameSets) {
  auto pre = fixtures::planted(64, 64, 2, 1.0f, false, 4);
  for (bool triangles : {true, false}) {
    auto t = fixtures::grid(6, 6, 0.25, triangles, 0.3);
    auto mesh = texsynth::build_mesh(t.input());
    auto field = texsynth::compute_orientation_field(mesh, texsynth::FieldParams());
    JumpSynthParams p;
    p.scale = 9.0;
    const auto plain = texsynth::synthesize_jumpmap(pre, mesh, field.data(), p);
    const int32_t S = plain.maps.num_blend_sets, L = plain.maps.num_corners;
    std::vector<float> base(size_t(L) * 2), pairs(size_t((S + 1) / 2) * L * 4, -7.f), weights(size_t(L) * S);
    texsynth::CornerMapsView view{L, S, base.data(), pairs.data(), weights.data()};
    view.packed_pairs = true;
    texsynth::synthesize_jumpmap(pre, mesh, field.data(), p, view);
    std::vector<float> repacked(pairs.size(), -7.f);
    texsynth::pack_set_pairs(plain.maps.blend_uv.data(), S, L, repacked.data());
    EXPECT_EQ(pairs, repacked);
    for (int32_t c = 0; c < L; ++c)
      for (int32_t s = 0; s < S + S % 2; ++s)
        for (int k = 0; k < 2; ++k)
          ASSERT_EQ(pairs[(size_t(s / 2) * L + c) * 4 + (s % 2) * 2 + k],
                    s < S ? plain.maps.blend_uv[(size_t(s) * L + c) * 2 + k] : 0.f);
    EXPECT_EQ(base, plain.maps.base_uv);
    EXPECT_EQ(weights, plain.maps.blend_weights);
  }
}
