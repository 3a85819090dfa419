// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "mesh_fixtures.hpp"
#include "texsynth/mesh/mesh.hpp"

using fixtures::TestMesh;
using texsynth::build_mesh;

namespace {

std::string error_of(const TestMesh& t) {
  try {
    build_mesh(t.input());
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

// Brute-force one-rings: every consecutive pair of every polygon, as a set per vertex.
std::vector<std::set<int32_t>> brute_rings(const TestMesh& t) {
  std::vector<std::set<int32_t>> rings(t.num_vertices());
  for (size_t p = 0; p < t.poly_starts.size(); ++p)
    for (int i = 0; i < t.poly_sizes[p]; ++i) {
      int32_t a = t.corner_verts[t.poly_starts[p] + i];
      int32_t b = t.corner_verts[t.poly_starts[p] + (i + 1) % t.poly_sizes[p]];
      if (a != b) rings[a].insert(b), rings[b].insert(a);
    }
  return rings;
}

void expect_rings_match(const TestMesh& t) {
  auto m = build_mesh(t.input());
  auto rings = brute_rings(t);
  ASSERT_EQ(m.neighbour_start.size(), size_t(t.num_vertices()) + 1);
  size_t total = 0;
  for (int32_t v = 0; v < t.num_vertices(); ++v) {
    std::vector<int32_t> got(m.neighbours.begin() + m.neighbour_start[v], m.neighbours.begin() + m.neighbour_start[v + 1]);
    EXPECT_EQ(got, std::vector<int32_t>(rings[v].begin(), rings[v].end())) << "vertex " << v;
    total += rings[v].size();
  }
  EXPECT_EQ(m.num_edges() * 2, int64_t(total));
}

}  // namespace

TEST(MeshBuild, OneRingsMatchBruteForceOnGridsAndSpheres) {
  expect_rings_match(fixtures::grid(7, 5, 1.0, true));
  expect_rings_match(fixtures::grid(6, 4, 1.0, false));
  expect_rings_match(fixtures::uv_sphere(8, 12, 1.0));
  expect_rings_match(fixtures::uv_sphere(9, 10, 1.0, 0.1));
}

TEST(MeshBuild, FlatGridNormalsPointUpAndSphereNormalsOutward) {
  auto g = fixtures::grid(5, 5, 0.5, true, 0.4);
  auto m = build_mesh(g.input());
  for (int32_t v = 0; v < m.num_vertices; ++v) {
    EXPECT_NEAR(m.normals[3 * v + 2], 1.0, 1e-6);
  }
  auto s = fixtures::uv_sphere(16, 24, 2.0);
  auto ms = build_mesh(s.input());
  for (int32_t v = 0; v < ms.num_vertices; ++v) {
    double px = s.positions[3 * v], py = s.positions[3 * v + 1], pz = s.positions[3 * v + 2];
    double r = std::sqrt(px * px + py * py + pz * pz);
    double d = (px * ms.normals[3 * v] + py * ms.normals[3 * v + 1] + pz * ms.normals[3 * v + 2]) / r;
    EXPECT_GT(d, 0.99) << "vertex " << v;
  }
}

TEST(MeshBuild, GivenNormalsAreNormalisedAndZeroOnesReplaced) {
  auto g = fixtures::grid(2, 2, 1.0, true);
  std::vector<float> normals(size_t(g.num_vertices()) * 3, 0.f);
  normals[0] = 3.f;  // vertex 0: +x (normalised); the rest zero -> computed (+z)
  auto m = build_mesh(g.input(), normals.data());
  EXPECT_FLOAT_EQ(m.normals[0], 1.f);
  EXPECT_FLOAT_EQ(m.normals[3 * 4 + 2], 1.f);
}

TEST(MeshBuild, CountsComponentsIgnoringLooseVertices) {
  TestMesh t = fixtures::grid(2, 2, 1.0, true);
  int32_t base = t.num_vertices();
  for (int i = 0; i < 3; ++i) t.add_vertex(10 + i, 0, 0);
  t.add_poly({base, base + 1, base + 2});
  t.add_vertex(50, 50, 50);  // loose
  auto m = build_mesh(t.input());
  EXPECT_EQ(m.num_components, 2);
  EXPECT_EQ(m.component[base + 3], -1);
  EXPECT_NE(m.component[0], m.component[base]);
}

TEST(MeshBuild, RejectsMalformedInputWithClearMessages) {
  TestMesh ok = fixtures::grid(2, 2, 1.0, true);
  {
    TestMesh t = ok;
    t.corner_verts[4] = 99;
    EXPECT_NE(error_of(t).find("references vertex 99"), std::string::npos) << error_of(t);
    t.corner_verts[4] = -1;
    EXPECT_NE(error_of(t).find("references vertex -1"), std::string::npos);
  }
  {
    TestMesh t = ok;
    t.poly_sizes[2] = 2;
    EXPECT_NE(error_of(t).find("polygon 2 has 2 corners"), std::string::npos) << error_of(t);
  }
  {
    TestMesh t = ok;
    t.poly_starts[3] += 1;
    EXPECT_NE(error_of(t).find("poly_starts[3]"), std::string::npos) << error_of(t);
  }
  {
    TestMesh t = ok;
    t.corner_verts.push_back(0);  // one corner no polygon covers
    EXPECT_NE(error_of(t).find("corners but corner_verts has"), std::string::npos) << error_of(t);
  }
  {
    TestMesh t = ok;
    t.poly_sizes.back() = 1000;
    EXPECT_NE(error_of(t).find("runs past"), std::string::npos) << error_of(t);
  }
  {
    TestMesh t = ok;
    t.positions[7] = std::numeric_limits<float>::quiet_NaN();
    EXPECT_NE(error_of(t).find("vertex 2 is NaN"), std::string::npos) << error_of(t);
    t.positions[7] = std::numeric_limits<float>::infinity();
    EXPECT_NE(error_of(t).find("vertex 2 is NaN or infinite"), std::string::npos);
  }
  {
    TestMesh t = ok;
    auto in = t.input();
    in.positions = nullptr;
    EXPECT_THROW(build_mesh(in), std::invalid_argument);
    in = t.input();
    in.num_corners = -3;
    EXPECT_THROW(build_mesh(in), std::invalid_argument);
  }
}

TEST(MeshBuild, ToleratesDegenerateButValidMeshes) {
  // empty
  TestMesh empty;
  auto me = build_mesh(empty.input());
  EXPECT_EQ(me.num_components, 0);
  EXPECT_EQ(me.num_edges(), 0);
  // zero-area (collinear) face, repeated vertex, duplicate vertex positions, non-manifold fan, 20-gon
  TestMesh t;
  int32_t a = t.add_vertex(0, 0, 0), b = t.add_vertex(1, 0, 0), c = t.add_vertex(2, 0, 0);
  t.add_poly({a, b, c});
  t.add_poly({a, a, a});
  int32_t d = t.add_vertex(0, 0, 0);  // duplicate of a
  t.add_poly({d, b, t.add_vertex(0, 1, 0)});
  for (int i = 0; i < 3; ++i) t.add_poly({a, b, t.add_vertex(0.5, std::cos(i), std::sin(i))});  // 3 faces on edge ab
  std::vector<int32_t> ring;
  for (int i = 0; i < 20; ++i) ring.push_back(t.add_vertex(5 + std::cos(i * 0.314), std::sin(i * 0.314), 0));
  t.add_poly(ring);
  auto m = build_mesh(t.input());
  for (float n : m.normals) EXPECT_TRUE(std::isfinite(n));
  expect_rings_match(t);
  EXPECT_EQ(m.degree(b), 7);  // a, c, d, (0,1,0) and the three fan tips
  EXPECT_EQ(m.max_poly_size(), 20);
  EXPECT_FALSE(m.all_triangles());
}

// Components from the parallel union-find against a breadth-first search from each lowest unvisited
// used vertex (the definition of the ids), on a shuffled mesh of several parts with loose vertices
// and a polygon whose corners are all one vertex, at 1 and 2 threads.
TEST(MeshBuild, ComponentIdsFollowTheLowestVertexAtAnyThreadCount) {
  fixtures::TestMesh t = fixtures::shuffled(fixtures::mixed_mesh(), 21);
  for (int k = 0; k < 5; ++k) t.add_vertex(900 + k, 0, 0);  // loose
  const int32_t lone = t.add_vertex(950, 0, 0);
  t.add_poly({lone, lone, lone});
  for (int k = 0; k < 3; ++k) t.add_vertex(960 + k, 0, 0);  // loose, after it
  const fixtures::TestMesh shuffled_again = fixtures::shuffled(t, 22);
  const texsynth::Mesh reference_adjacency = texsynth::build_mesh(shuffled_again.input());
  const int32_t nv = reference_adjacency.num_vertices;
  std::vector<char> used(size_t(nv), 0);
  for (int32_t v : shuffled_again.corner_verts) used[v] = 1;
  std::vector<int32_t> expected(size_t(nv), -1), queue;
  int32_t count = 0;
  for (int32_t s = 0; s < nv; ++s) {
    if (!used[s] || expected[s] >= 0) continue;
    expected[s] = count;
    queue.assign(1, s);
    for (size_t h = 0; h < queue.size(); ++h)
      for (int32_t k = reference_adjacency.neighbour_start[queue[h]]; k < reference_adjacency.neighbour_start[queue[h] + 1]; ++k)
        if (expected[reference_adjacency.neighbours[k]] < 0)
          expected[reference_adjacency.neighbours[k]] = count, queue.push_back(reference_adjacency.neighbours[k]);
    ++count;
  }
  EXPECT_EQ(count, 4);  // grid, sphere, hexagon strip, the one-vertex polygon
  EXPECT_EQ(std::count(expected.begin(), expected.end(), -1), 8);
  for (int threads : {1, 2}) {
    tbb::global_control control(tbb::global_control::max_allowed_parallelism, threads);
    const texsynth::Mesh m = texsynth::build_mesh(shuffled_again.input());
    EXPECT_EQ(m.num_components, count) << threads << " threads";
    EXPECT_EQ(m.component, expected) << threads << " threads";
  }
}
