// SPDX-License-Identifier: GPL-3.0-or-later
// Texton-string synthesis on meshes: similarity maps, planted continuation, blend sets, E_t,
// thread-count determinism, input validation.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <utility>
#include <vector>

#include "blend_checks.hpp"
#include "mesh_fixtures.hpp"
#include "texton_fixtures.hpp"
#include "texsynth/field/orientation_field.hpp"
#include "texsynth/mesh/mesh.hpp"
#include "texsynth/mesh/mesh_edges.hpp"
#include "texsynth/synth/texton_synth.hpp"

namespace {

struct SynthRun {
  texsynth::Mesh mesh;
  std::vector<float> up;
  texsynth::TextonSynthResult result;
};

SynthRun run(const fixtures::TestMesh& tm, const texsynth::Preprocessed& pre, const std::vector<float>& pixels,
        texsynth::TextonSynthParams p, texsynth::Vec3f axis = {0.f, 1.f, 0.f}) {
  SynthRun r;
  r.mesh = texsynth::build_mesh(tm.input());
  texsynth::FieldParams fp;
  fp.axis = axis;
  r.up = texsynth::compute_orientation_field(r.mesh, fp);
  texsynth::SampleImage s{pixels.data(), pre.width, pre.height, 3};
  r.result = texsynth::synthesize_texton(pre, r.mesh, r.up.data(), s, p);
  return r;
}

std::array<std::array<double, 3>, 3> corner_positions(const fixtures::TestMesh& tm, const int32_t* corners) {
  std::array<std::array<double, 3>, 3> p;
  for (int i = 0; i < 3; ++i)
    for (int a = 0; a < 3; ++a) p[i][a] = tm.positions[3 * size_t(tm.corner_verts[corners[i]]) + a];
  return p;
}

// Every polygon's base mapping (and, with sets = true, every blend set: flat meshes) is a similarity
// (numeric Jacobian from the corners: equal singular values, not mirrored); the base has exactly
// scale × mean multiplier.
void expect_similarities(const fixtures::TestMesh& tm, const texsynth::Preprocessed& pre, const SynthRun& r,
                         const std::vector<float>& mult, double scale, bool sets) {
  const auto& maps = r.result.maps;
  const size_t L = size_t(maps.num_corners);
  int checked = 0;
  for (size_t poly = 0; poly < tm.poly_starts.size(); ++poly) {
    const int32_t first = tm.poly_starts[poly], n = tm.poly_sizes[poly];
    double mean = 0;
    for (int i = 0; i < n; ++i) mean += mult[tm.corner_verts[first + i]];
    mean /= n;
    for (int32_t t = 1; t + 1 < n; ++t) {  // fan triangles (0, t, t+1) of planar polygons
      const int32_t corners[3] = {first, first + t, first + t + 1};
      const auto p = corner_positions(tm, corners);
      for (int set = -1; set < (sets ? maps.num_blend_sets : 0); ++set) {
        const float* uv = set < 0 ? maps.base_uv.data() : maps.blend_uv.data() + size_t(set) * L * 2;
        std::array<std::array<double, 2>, 3> tri;
        bool clamped = false;  // a vertex mapping clamped at the sample border (stats.clipped_blend_sets)
        for (int i = 0; i < 3; ++i) {
          tri[i] = {uv[2 * size_t(corners[i])], uv[2 * size_t(corners[i]) + 1]};
          for (double x : tri[i]) clamped = clamped || (set >= 0 && (x == 0.0 || x == 1.0));
        }
        if (clamped) continue;
        fixtures::FaceMap f;
        ASSERT_TRUE(fixtures::face_map(p, tri, pre.width, pre.height, f));
        const auto sv = fixtures::singular_values(f.J);
        EXPECT_NEAR(sv[0] / sv[1], 1.0, 2e-3) << "poly " << poly << " set " << set;
        EXPECT_LT(f.J[0][0] * f.J[1][1] - f.J[0][1] * f.J[1][0], 0.0);  // texel y down: det < 0 = unmirrored
        if (set < 0) EXPECT_NEAR(sv[0], scale * mean, 2e-3 * scale * mean);
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 100);
}

TEST(TextonSynth, EveryMappingIsASimilarityOnACurvedMesh) {
  const auto pre = fixtures::label_sample(128, 128, 30, false);
  const auto pixels = fixtures::label_colours(pre);
  const auto tm = fixtures::uv_sphere(10, 14, 1.0, 0.1);
  std::vector<float> mult(size_t(tm.num_vertices()));
  texsynth::Rng rng(4);
  for (auto& m : mult) m = float(0.8 + 0.4 * rng.uniform());
  texsynth::TextonSynthParams p;
  p.scale = 20.0;
  p.scale_multiplier = mult.data();
  const SynthRun r = run(tm, pre, pixels, p, {0.f, 0.f, 1.f});
  EXPECT_EQ(r.result.maps.num_blend_sets, 4);
  EXPECT_GT(r.result.stats.searched_faces, 0);
  // Blend sets unfold edges in their owner polygon's frame: not similarities on this rough sphere,
  // but continuous across every edge.
  expect_similarities(tm, pre, r, mult, p.scale, false);
  EXPECT_GT(fixtures::expect_c0_across_edges(tm, r.result.maps, 4), int(tm.poly_starts.size()));
  for (float u : r.result.maps.base_uv) EXPECT_TRUE(u >= 0.f && u <= 1.f);
}

TEST(TextonSynth, QuadsAreSimilaritiesWithFourBlendSets) {
  const auto pre = fixtures::label_sample(96, 96, 20, false);
  const auto pixels = fixtures::label_colours(pre);
  const auto tm = fixtures::grid(8, 8, 0.5, false, 0.3);
  std::vector<float> mult(size_t(tm.num_vertices()), 1.f);
  texsynth::TextonSynthParams p;
  p.scale = 12.0;
  const SynthRun r = run(tm, pre, pixels, p);
  EXPECT_EQ(r.result.maps.num_blend_sets, 4);
  expect_similarities(tm, pre, r, mult, p.scale, true);  // flat: the vertex mappings are similarities too
  EXPECT_GT(fixtures::expect_c0_across_edges(tm, r.result.maps, 4), int(tm.poly_starts.size()));
}

// The planted flat grid: random labels (K = 64) on a tileable 64² sample, a 6×6 triangle grid with
// one frame, 7 texels per unit.
struct PlantedGrid {
  texsynth::Preprocessed pre = fixtures::label_sample(64, 64, 64, true, 31);
  std::vector<float> pixels = fixtures::label_colours(pre);
  fixtures::TestMesh tm = fixtures::grid(6, 6, 1.0, true);
  static texsynth::TextonSynthParams params() {
    texsynth::TextonSynthParams p;
    p.scale = 7.0;
    return p;
  }
};

// The continuing origin is the only zero of Eq. 2, so every face of the planted grid continues its
// neighbours: shared vertices get the same texel from both sides and E_t vanishes on every edge.
TEST(TextonSynth, PlantedFlatGridContinuesEveryNeighbour) {
  const PlantedGrid g;
  const auto& tm = g.tm;
  texsynth::TextonSynthParams p = PlantedGrid::params();
  p.seed = 3;
  const SynthRun r = run(tm, g.pre, g.pixels, p);
  EXPECT_EQ(r.result.stats.searched_faces, int64_t(tm.poly_starts.size()) - 1);
  EXPECT_EQ(r.result.stats.fallback_faces, 0);
  for (float e : r.result.edge_error) EXPECT_LT(e, 1e-3f);
  // Shared vertices agree modulo the tile period.
  const auto& uv = r.result.maps.base_uv;
  std::vector<std::array<double, 2>> at(size_t(tm.num_vertices()), {NAN, NAN});
  for (size_t c = 0; c < tm.corner_verts.size(); ++c) {
    auto& a = at[tm.corner_verts[c]];
    const double x = uv[2 * c] * 64, y = (1 - uv[2 * c + 1]) * 64;
    if (std::isnan(a[0])) {
      a = {x, y};
      continue;
    }
    EXPECT_NEAR(std::remainder(x - a[0], 64.0), 0.0, 1e-3);
    EXPECT_NEAR(std::remainder(y - a[1], 64.0), 0.0, 1e-3);
  }
}

TEST(TextonSynth, RandomPlacementHasLargeEdgeErrorSoThePlantedTestCanFail) {
  // The planted grid with one voting point and m = 1: Eq. 2 can no longer reject wrong origins.
  const PlantedGrid g;
  texsynth::TextonSynthParams p = PlantedGrid::params();
  p.search.top_m = 1, p.search.max_vote_points = 1;
  p.search.coherence_threshold = 0;  // else the continuation is taken without any vote
  const SynthRun r = run(g.tm, g.pre, g.pixels, p);
  double sum = 0;
  for (float e : r.result.edge_error) sum += e;
  EXPECT_GT(sum / r.result.edge_error.size(), 0.05);
}

// Each corner of a blended polygon has weight 1 on its set (triangles 0, 1, 3; quads 0..3) and that
// set is its vertex's mapping: at the vertex it equals the base UV of the vertex in one of its
// polygons (the owner). Unblended polygons (Φ threshold) have no weight at all.
TEST(TextonSynth, BlendSetsAreVertexMappingsWithOneHotWeights) {
  const auto pre = fixtures::label_sample(96, 96, 20, false);
  const auto pixels = fixtures::label_colours(pre);
  for (bool triangles : {true, false}) {
    const auto tm = fixtures::grid(5, 5, 1.0, triangles, 0.4);
    texsynth::TextonSynthParams p;
    p.scale = 8.0;
    const SynthRun r = run(tm, pre, pixels, p);
    const auto& maps = r.result.maps;
    const size_t L = size_t(maps.num_corners);
    ASSERT_EQ(maps.num_blend_sets, 4);
    for (size_t poly = 0; poly < tm.poly_starts.size(); ++poly) {
      const int32_t first = tm.poly_starts[poly], n = tm.poly_sizes[poly];
      for (int32_t i = 0; i < n; ++i) {
        const int32_t c = first + i, set = texsynth::kCornerSet[n - 3][i];
        for (int s = 0; s < 4; ++s) EXPECT_EQ(maps.blend_weights[size_t(c) * 4 + s], s == set ? 1.f : 0.f);
        const float* at = &maps.blend_uv[(size_t(set) * L + c) * 2];
        bool owner_found = false;
        for (size_t d = 0; d < L; ++d)
          owner_found = owner_found || (tm.corner_verts[d] == tm.corner_verts[c] && maps.base_uv[2 * d] == at[0] &&
                                        maps.base_uv[2 * d + 1] == at[1]);
        EXPECT_TRUE(owner_found) << "corner " << c << ": set " << set << " is not its vertex's owner mapping";
      }
    }
    EXPECT_GT(fixtures::expect_c0_across_edges(tm, maps, 4), int(tm.poly_starts.size()));
    // With a threshold no edge passes, no polygon is blended: every weight is 0 (own patches only).
    p.has_camera = true;
    p.camera[2] = 10.0;
    p.blend_threshold = 1e30;
    const SynthRun none = run(tm, pre, pixels, p);
    EXPECT_EQ(none.result.stats.blended_edges, 0);
    for (float w : none.result.maps.blend_weights) EXPECT_EQ(w, 0.f);
  }
}

TEST(TextonSynth, DeterministicAcrossThreadCounts) {
  const auto pre = fixtures::label_sample(128, 128, 40, false);
  const auto pixels = fixtures::label_colours(pre);
  const auto tm = fixtures::uv_sphere(40, 60, 1.0, 0.05);
  texsynth::TextonSynthParams p;
  p.scale = 60.0;
  p.seed = 12;
  p.has_camera = true;
  p.camera[0] = 3, p.camera[1] = 1, p.camera[2] = 0.5;
  SynthRun one, two;
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
    one = run(tm, pre, pixels, p);
  }
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 4);
    two = run(tm, pre, pixels, p);
  }
  EXPECT_EQ(one.result.maps.base_uv, two.result.maps.base_uv);
  EXPECT_EQ(one.result.maps.blend_uv, two.result.maps.blend_uv);
  EXPECT_EQ(one.result.maps.blend_weights, two.result.maps.blend_weights);
  EXPECT_EQ(one.result.edge_error, two.result.edge_error);
  EXPECT_EQ(0, std::memcmp(one.result.edge_phi.data(), two.result.edge_phi.data(), one.result.edge_phi.size() * 4));
  p.seed = 13;
  const SynthRun other = run(tm, pre, pixels, p);
  EXPECT_NE(one.result.maps.base_uv, other.result.maps.base_uv);
}

TEST(TextonSynth, BadInputThrowsAndNamesTheProblem) {
  auto pre = fixtures::label_sample(32, 32, 5, false);
  const auto pixels = fixtures::label_colours(pre);
  const auto tm = fixtures::grid(3, 3, 1.0, true);
  const texsynth::Mesh mesh = texsynth::build_mesh(tm.input());
  std::vector<float> up(size_t(mesh.num_vertices) * 3, 0.f);
  for (int32_t v = 0; v < mesh.num_vertices; ++v) up[3 * size_t(v) + 1] = 1.f;
  texsynth::SampleImage s{pixels.data(), 32, 32, 3};
  texsynth::TextonSynthParams p;
  p.scale = 4.0;
  auto message = [&](const texsynth::Preprocessed& pr, const texsynth::SampleImage& si, const texsynth::TextonSynthParams& pp,
                     const float* orient) -> std::string {
    try {
      texsynth::synthesize_texton(pr, mesh, orient, si, pp);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_EQ(message(pre, s, p, up.data()), "");
  texsynth::SampleImage wrong = s;
  wrong.width = 31;
  EXPECT_NE(message(pre, wrong, p, up.data()).find("sample_pixels"), std::string::npos);
  auto q = p;
  q.blend_threshold = 1.0;
  EXPECT_NE(message(pre, s, q, up.data()).find("camera"), std::string::npos);
  q = p;
  q.scale = 100.0;
  EXPECT_NE(message(pre, s, q, up.data()).find("larger than"), std::string::npos);
  q.allow_oversized = true;
  EXPECT_EQ(message(pre, s, q, up.data()), "");
  auto bad_up = up;
  bad_up[4] = NAN;
  EXPECT_NE(message(pre, s, p, bad_up.data()).find("orientation"), std::string::npos);
  auto broken = pre;
  for (int32_t px = 0; px < 32 * 32; ++px)  // a pixel of another texton listed in bucket 0
    if (broken.texton_map[px] != 0) broken.bucket_pixels[0] = px;
  EXPECT_NE(message(broken, s, p, up.data()).find("bucket"), std::string::npos);
  broken = pre;
  broken.texton_map[3] = 99;
  EXPECT_NE(message(broken, s, p, up.data()).find("texton map"), std::string::npos);
  broken = pre;
  broken.texton_distances[1] = NAN;
  EXPECT_NE(message(broken, s, p, up.data()).find("distance"), std::string::npos);
}

// Faces many times the sample with allow_oversized: centred origins far outside the sample never
// index the vote counters out of bounds, and every UV stays finite and inside [0, 1].
TEST(TextonSynth, OversizedFacesAreMappedSafely) {
  for (bool tileable : {false, true}) {
    const auto pre = fixtures::label_sample(32, 24, 6, tileable);
    const auto pixels = fixtures::label_colours(pre);
    fixtures::TestMesh tm;  // a long thin strip of triangles, each ~10x the sample along x
    for (int i = 0; i <= 6; ++i) tm.add_vertex(10.0 * i, 0, 0), tm.add_vertex(10.0 * i, 0.3, 0);
    for (int i = 0; i < 6; ++i) tm.add_poly({2 * i, 2 * i + 2, 2 * i + 3}), tm.add_poly({2 * i, 2 * i + 3, 2 * i + 1});
    texsynth::TextonSynthParams p;
    p.scale = 30.0;
    p.allow_oversized = true;
    const SynthRun r = run(tm, pre, pixels, p);
    EXPECT_EQ(r.result.stats.oversized_faces, 12);
    for (float u : r.result.maps.base_uv) EXPECT_TRUE(std::isfinite(u) && (tileable || (u >= 0.f && u <= 1.f)));
    for (float u : r.result.maps.blend_uv) EXPECT_TRUE(std::isfinite(u));
  }
}

}  // namespace

namespace {

double mean_error(const texsynth::TextonSynthResult& r) {
  double sum = 0;
  int64_t count = 0;
  for (int32_t e = 0; e < r.edges.num_edges(); ++e)
    if (r.edges.edge_corner_start[e + 1] - r.edges.edge_corner_start[e] >= 2) sum += r.edge_error[e], ++count;
  return sum / double(count);
}

// With coherence on, every face of the planted flat grid takes its neighbour's exact continuation
// without voting, and E_t still vanishes.
TEST(TextonSynth, CoherenceTakesThePlantedContinuationWithoutVoting) {
  const PlantedGrid g;
  texsynth::TextonSynthParams p = PlantedGrid::params();
  p.seed = 3;
  p.search.coherence_threshold = 0.05;
  const SynthRun r = run(g.tm, g.pre, g.pixels, p);
  const int64_t faces = int64_t(g.tm.poly_starts.size());
  EXPECT_EQ(r.result.stats.searched_faces, faces - 1);
  EXPECT_EQ(r.result.stats.coherent_faces, faces - 1);
  for (float e : r.result.edge_error) EXPECT_LT(e, 1e-3f);
  p.search.coherence_threshold = 0;
  EXPECT_EQ(run(g.tm, g.pre, g.pixels, p).result.stats.coherent_faces, 0);
}

// Regions: several per component, deterministic at 1, 2 and 4 threads, every face textured once
// (regions + border pass), and E_t no worse than the sequential growth beyond 10% on a curved mesh.
TEST(TextonSynth, RegionGrowthIsDeterministicAndKeepsTheSeamError) {
  const auto pre = fixtures::label_sample(128, 128, 40, false);
  const auto pixels = fixtures::label_colours(pre);
  const auto tm = fixtures::uv_sphere(40, 60, 1.0, 0.05);
  texsynth::TextonSynthParams p;
  p.scale = 60.0;
  p.seed = 12;
  p.seeds_per_component = 1, p.search.coherence_threshold = 0;  // the original growth
  const double sequential = mean_error(run(tm, pre, pixels, p).result);
  p.seeds_per_component = 8;
  p.search.coherence_threshold = 0.1;
  SynthRun runs[3];
  const int threads[3] = {1, 2, 4};
  for (int i = 0; i < 3; ++i) {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, threads[i]);
    runs[i] = run(tm, pre, pixels, p);
  }
  const auto& st = runs[0].result.stats;
  EXPECT_EQ(st.regions, 8);
  EXPECT_GT(st.border_faces, 0);
  EXPECT_EQ(st.searched_faces + st.fallback_faces + st.regions, st.faces);
  int64_t in_regions = 0;
  for (int32_t region : runs[0].result.face_region) in_regions += region >= 0;
  EXPECT_EQ(in_regions + st.border_faces, st.faces);
  for (int i = 1; i < 3; ++i) {
    EXPECT_EQ(runs[0].result.maps.base_uv, runs[i].result.maps.base_uv) << threads[i];
    EXPECT_EQ(runs[0].result.maps.blend_uv, runs[i].result.maps.blend_uv) << threads[i];
    EXPECT_EQ(runs[0].result.face_region, runs[i].result.face_region) << threads[i];
    EXPECT_EQ(runs[0].result.edge_error, runs[i].result.edge_error) << threads[i];
  }
  EXPECT_LE(mean_error(runs[0].result), sequential * 1.10);
  // Small components keep one seed: below 2 × kMinRegionFaces faces.
  const auto small = fixtures::grid(10, 10, 1.0, true);
  p.scale = 7.0;
  EXPECT_EQ(run(small, pre, pixels, p).result.stats.regions, 1);
}

TEST(TextonSynth, BadGrowthParametersAreRefused) {
  const auto pre = fixtures::label_sample(32, 32, 5, false);
  const auto pixels = fixtures::label_colours(pre);
  const auto tm = fixtures::grid(3, 3, 1.0, true);
  texsynth::TextonSynthParams p;
  p.scale = 4.0;
  auto message = [&](const texsynth::TextonSynthParams& pp) -> std::string {
    try {
      run(tm, pre, pixels, pp);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "";
  };
  for (double bad : {-0.1, double(NAN), double(INFINITY)}) {
    auto q = p;
    q.search.coherence_threshold = bad;
    EXPECT_NE(message(q).find("coherence_threshold"), std::string::npos) << bad;
  }
  for (int bad : {0, -3, 5000}) {
    auto q = p;
    q.seeds_per_component = bad;
    EXPECT_NE(message(q).find("seeds_per_component"), std::string::npos) << bad;
  }
  auto ok = p;
  ok.seeds_per_component = 4096, ok.search.coherence_threshold = 0.2;
  EXPECT_EQ(message(ok), "");
}

}  // namespace

// The parallel edge table against its definition, built by brute force: edges are the distinct
// (a, b), a < b, of consecutive corners, sorted; each lists its corners ascending. On a shuffled
// mixed mesh plus a non-manifold fan (three triangles on one edge) and a polygon with a repeated
// vertex (a zero-length corner edge: -1).
TEST(TextonSynth, EdgeTableMatchesItsDefinitionAtOneAndTwoThreads) {
  fixtures::TestMesh tm = fixtures::shuffled(fixtures::mixed_mesh(), 11);
  const int32_t a = tm.add_vertex(500, 0, 0), b = tm.add_vertex(501, 0, 0);
  for (int k = 0; k < 3; ++k) tm.add_poly({a, b, tm.add_vertex(500.5, 1, k)});
  const int32_t c = tm.add_vertex(510, 0, 0), d = tm.add_vertex(511, 0, 0), f = tm.add_vertex(511, 1, 0);
  tm.add_poly({c, d, d, f});
  const texsynth::Mesh mesh = texsynth::build_mesh(tm.input());
  std::vector<std::pair<int32_t, int32_t>> pairs;
  std::vector<std::pair<int32_t, int32_t>> corner_pair(tm.corner_verts.size(), {-1, -1});
  for (size_t p = 0; p < tm.poly_starts.size(); ++p)
    for (int32_t i = 0; i < tm.poly_sizes[p]; ++i) {
      const int32_t first = tm.poly_starts[p];
      const int32_t u = tm.corner_verts[first + i], w = tm.corner_verts[first + (i + 1) % tm.poly_sizes[p]];
      if (u == w) continue;
      corner_pair[first + i] = {std::min(u, w), std::max(u, w)};
      pairs.push_back(corner_pair[first + i]);
    }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  for (int threads : {1, 2}) {
    tbb::global_control control(tbb::global_control::max_allowed_parallelism, threads);
    const texsynth::MeshEdges e = texsynth::build_mesh_edges(mesh);
    ASSERT_EQ(e.num_edges(), int32_t(pairs.size())) << threads << " threads";
    for (size_t i = 0; i < pairs.size(); ++i)
      ASSERT_EQ(std::make_pair(e.vertices[2 * i], e.vertices[2 * i + 1]), pairs[i]) << "edge " << i;
    std::vector<std::vector<int32_t>> expected(pairs.size());
    int32_t degenerate = 0;
    for (size_t corner = 0; corner < corner_pair.size(); ++corner) {
      if (corner_pair[corner].first < 0) {
        EXPECT_EQ(e.corner_edge[corner], -1);
        ++degenerate;
        continue;
      }
      const size_t id = std::lower_bound(pairs.begin(), pairs.end(), corner_pair[corner]) - pairs.begin();
      ASSERT_EQ(e.corner_edge[corner], int32_t(id)) << "corner " << corner;
      expected[id].push_back(int32_t(corner));
    }
    EXPECT_EQ(degenerate, 1);
    size_t non_manifold = 0;
    for (size_t i = 0; i < pairs.size(); ++i) {
      non_manifold += expected[i].size() == 3;
      ASSERT_EQ(std::vector<int32_t>(e.edge_corners.begin() + e.edge_corner_start[i],
                                     e.edge_corners.begin() + e.edge_corner_start[i + 1]),
                expected[i])
          << "edge " << i;
    }
    EXPECT_EQ(non_manifold, 1u);
  }
}

// Outputs written into caller buffers (the bindings' numpy arrays, uninitialised): every element
// is written, with the values of the vector form; the packed layout is pack_set_pairs of the sets.
TEST(TextonSynth, OutputViewWritesEveryElementWithTheVectorValues) {
  const auto pre = fixtures::label_sample(96, 96, 24, false);
  const auto pixels = fixtures::label_colours(pre);
  const fixtures::TestMesh tm = fixtures::shuffled(fixtures::mixed_mesh(), 12);
  for (bool blend : {true, false})
    for (bool packed : {false, true}) {
      texsynth::TextonSynthParams p;
      p.scale = 4.0;
      p.seed = 3;
      p.blend = blend;
      const SynthRun reference = run(tm, pre, pixels, p);
      const texsynth::CornerMaps& maps = reference.result.maps;
      const size_t L = size_t(maps.num_corners), S = size_t(texsynth::texton_blend_sets(blend));
      ASSERT_EQ(size_t(maps.num_blend_sets), S);
      std::vector<float> base(L * 2, -7.f), sets(packed ? (S + 1) / 2 * L * 4 : S * L * 2, -7.f), weights(L * S, -7.f);
      texsynth::CornerMapsView view{maps.num_corners, int32_t(S), base.data(), sets.data(), weights.data()};
      view.packed_pairs = packed;
      texsynth::SampleImage s{pixels.data(), pre.width, pre.height, 3};
      const texsynth::TextonSynthResult r = texsynth::synthesize_texton(pre, reference.mesh, reference.up.data(), s, p, view);
      EXPECT_TRUE(r.maps.base_uv.empty());
      EXPECT_EQ(base, maps.base_uv);
      EXPECT_EQ(weights, maps.blend_weights);
      std::vector<float> expected_sets = maps.blend_uv;
      if (packed) {
        expected_sets.assign(sets.size(), -1.f);
        texsynth::pack_set_pairs(maps.blend_uv.data(), int32_t(S), int32_t(L), expected_sets.data());
      }
      EXPECT_EQ(sets, expected_sets) << "blend " << blend << ", packed " << packed;
      EXPECT_EQ(r.edge_error, reference.result.edge_error);
      texsynth::CornerMapsView wrong = view;
      wrong.num_blend_sets = int32_t(S) + 1;
      EXPECT_THROW(texsynth::synthesize_texton(pre, reference.mesh, reference.up.data(), s, p, wrong), std::invalid_argument);
    }
}
