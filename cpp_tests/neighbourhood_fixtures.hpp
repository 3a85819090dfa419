// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Triangle meshes (Blender loop-triangle layout) and sample points for the round-ring tests and
// benchmark: icosphere, split-vertex copies, closed thin box, T-fin, random barycentric samples.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <utility>
#include <vector>

#include "mesh_fixtures.hpp"
#include "texsynth/common/rng.hpp"
#include "texsynth/neighbourhood/round_rings.hpp"
#include "texsynth/particles/surface_walk.hpp"

namespace ring_fixtures {

struct TriMesh {
  std::vector<float> positions;
  std::vector<int32_t> triangles;

  int32_t add_vertex(double x, double y, double z) {
    positions.insert(positions.end(), {float(x), float(y), float(z)});
    return int32_t(positions.size() / 3 - 1);
  }
  void add_triangle(int32_t a, int32_t b, int32_t c) { triangles.insert(triangles.end(), {a, b, c}); }
  int32_t num_vertices() const { return int32_t(positions.size() / 3); }
  int32_t num_triangles() const { return int32_t(triangles.size() / 3); }
  texsynth::TriangleMeshInput input() const {
    texsynth::TriangleMeshInput in;
    in.positions = positions.data();
    in.num_vertices = num_vertices();
    in.triangles = triangles.data();
    in.num_triangles = num_triangles();
    return in;
  }
  std::array<double, 3> vertex(int32_t v) const {
    return {positions[3 * size_t(v)], positions[3 * size_t(v) + 1], positions[3 * size_t(v) + 2]};
  }
  std::array<double, 3> corner(int32_t t, int k) const { return vertex(triangles[3 * size_t(t) + k]); }
  // P = (1 - b1 - b2) p0 + b1 p1 + b2 p2.
  std::array<double, 3> point(int32_t t, double b1, double b2) const {
    auto p0 = corner(t, 0), p1 = corner(t, 1), p2 = corner(t, 2);
    std::array<double, 3> p;
    for (int k = 0; k < 3; ++k) p[k] = (1 - b1 - b2) * p0[k] + b1 * p1[k] + b2 * p2[k];
    return p;
  }
  std::array<double, 3> point(const texsynth::RingPoint& rp) const {
    return point(rp.triangle, rp.b1 / 65535.0, rp.b2 / 65535.0);
  }
};

// The point of the mesh nearest to x among faces whose plane projection of x falls inside them
// (triangle -1 when none).
inline texsynth::SurfacePoint locate(const TriMesh& m, texsynth::V3 x) {
  texsynth::SurfacePoint best;
  double best_d = std::numeric_limits<double>::infinity();
  auto at = [&](int32_t t, int k) {
    const auto p = m.corner(t, k);
    return texsynth::V3{p[0], p[1], p[2]};
  };
  for (int32_t t = 0; t < m.num_triangles(); ++t) {
    const texsynth::V3 p0 = at(t, 0), e1 = at(t, 1) - p0, e2 = at(t, 2) - p0, n = texsynth::cross(e1, e2);
    const double n2 = texsynth::dot(n, n);
    const texsynth::V3 q = x - p0;
    const double b1 = texsynth::dot(texsynth::cross(q, e2), n) / n2, b2 = texsynth::dot(texsynth::cross(e1, q), n) / n2;
    if (b1 < 0 || b2 < 0 || b1 + b2 > 1) continue;
    const double d = std::fabs(texsynth::dot(q, n)) / std::sqrt(n2);
    if (d < best_d) best_d = d, best = {t, b1, b2};
  }
  return best;
}

// Triangulated grid (fixtures::grid with triangles = true), corner order kept.
inline TriMesh plane(int nx, int ny, double spacing, double jitter, uint64_t seed = 1) {
  fixtures::TestMesh g = fixtures::grid(nx, ny, spacing, true, jitter, seed);
  TriMesh m;
  m.positions = g.positions;
  m.triangles = g.corner_verts;
  return m;
}

// Open cylinder of radius r around z, `segments` around and `rows` rows of height `dz`, outward-facing.
inline TriMesh cylinder(int segments, int rows, double r, double dz) {
  constexpr double kTwoPi = 6.28318530717958647692;
  TriMesh m;
  for (int j = 0; j <= rows; ++j)
    for (int i = 0; i < segments; ++i) {
      const double a = kTwoPi * i / segments;
      m.add_vertex(r * std::cos(a), r * std::sin(a), j * dz);
    }
  auto id = [&](int i, int j) { return int32_t(j * segments + (i % segments)); };
  for (int j = 0; j < rows; ++j)
    for (int i = 0; i < segments; ++i) {
      m.add_triangle(id(i, j), id(i + 1, j), id(i + 1, j + 1));
      m.add_triangle(id(i, j), id(i + 1, j + 1), id(i, j + 1));
    }
  return m;
}

// Subdivided icosahedron projected onto the sphere of radius `radius`, outward-facing.
inline TriMesh icosphere(int subdivisions, double radius) {
  std::vector<std::array<double, 3>> v;
  const double t = (1 + std::sqrt(5.0)) / 2;
  for (auto p : std::vector<std::array<double, 3>>{{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                                                   {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}}) {
    const double l = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    v.push_back({p[0] / l, p[1] / l, p[2] / l});
  }
  std::vector<std::array<int32_t, 3>> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                           {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                           {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                           {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int s = 0; s < subdivisions; ++s) {
    std::map<std::pair<int32_t, int32_t>, int32_t> mid;
    auto midpoint = [&](int32_t a, int32_t b) {
      auto key = std::make_pair(std::min(a, b), std::max(a, b));
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      std::array<double, 3> p{v[a][0] + v[b][0], v[a][1] + v[b][1], v[a][2] + v[b][2]};
      const double l = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
      v.push_back({p[0] / l, p[1] / l, p[2] / l});
      return mid[key] = int32_t(v.size() - 1);
    };
    std::vector<std::array<int32_t, 3>> next;
    for (auto& tri : f) {
      int32_t a = midpoint(tri[0], tri[1]), b = midpoint(tri[1], tri[2]), c = midpoint(tri[2], tri[0]);
      next.push_back({tri[0], a, c});
      next.push_back({tri[1], b, a});
      next.push_back({tri[2], c, b});
      next.push_back({a, b, c});
    }
    f.swap(next);
  }
  TriMesh m;
  for (auto& p : v) m.add_vertex(p[0] * radius, p[1] * radius, p[2] * radius);
  for (auto& tri : f) m.add_triangle(tri[0], tri[1], tri[2]);
  return m;
}

// Every triangle with its own three vertices at the same positions (an unwelded import).
inline TriMesh split_vertices(const TriMesh& m) {
  TriMesh s;
  for (int32_t t = 0; t < m.num_triangles(); ++t) {
    int32_t ids[3];
    for (int k = 0; k < 3; ++k) {
      auto p = m.corner(t, k);
      ids[k] = s.add_vertex(p[0], p[1], p[2]);
    }
    s.add_triangle(ids[0], ids[1], ids[2]);
  }
  return s;
}

// Closed flat box: top z = +h/2 (normals +z), bottom z = -h/2 (normals -z), rim strips joining their
// borders, n×n cells of size `spacing` on each sheet. Returns the mesh; top triangles come first
// (2·n² of them).
inline TriMesh thin_box(int n, double spacing, double h) {
  TriMesh m;
  auto top = [&](int x, int y) { return int32_t(y * (n + 1) + x); };
  auto bottom = [&](int x, int y) { return int32_t((n + 1) * (n + 1) + y * (n + 1) + x); };
  for (double z : {h / 2, -h / 2})
    for (int y = 0; y <= n; ++y)
      for (int x = 0; x <= n; ++x) m.add_vertex(x * spacing, y * spacing, z);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      m.add_triangle(top(x, y), top(x + 1, y), top(x + 1, y + 1));
      m.add_triangle(top(x, y), top(x + 1, y + 1), top(x, y + 1));
    }
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      m.add_triangle(bottom(x, y), bottom(x + 1, y + 1), bottom(x + 1, y));
      m.add_triangle(bottom(x, y), bottom(x, y + 1), bottom(x + 1, y + 1));
    }
  // Border loop counter-clockwise seen from +z; the rim walks each top border edge backwards.
  std::vector<std::pair<int, int>> loop;
  for (int x = 0; x < n; ++x) loop.push_back({x, 0});
  for (int y = 0; y < n; ++y) loop.push_back({n, y});
  for (int x = n; x > 0; --x) loop.push_back({x, n});
  for (int y = n; y > 0; --y) loop.push_back({0, y});
  for (size_t i = 0; i < loop.size(); ++i) {
    auto a = loop[i], b = loop[(i + 1) % loop.size()];
    int32_t ta = top(a.first, a.second), tb = top(b.first, b.second);
    int32_t ba = bottom(a.first, a.second), bb = bottom(b.first, b.second);
    m.add_triangle(tb, ta, ba);
    m.add_triangle(tb, ba, bb);
  }
  return m;
}

struct Points {
  std::vector<int32_t> triangle;
  std::vector<float> barycentric, radius;
  void add(int32_t t, double b1, double b2, double r) {
    triangle.push_back(t);
    barycentric.insert(barycentric.end(), {float(b1), float(b2)});
    radius.push_back(float(r));
  }
  texsynth::SurfacePoints input() const {
    texsynth::SurfacePoints p;
    p.triangle = triangle.data();
    p.barycentric = barycentric.data();
    p.radius = radius.data();
    p.num_points = int32_t(triangle.size());
    return p;
  }
  int32_t size() const { return int32_t(triangle.size()); }
};

// n points uniformly on the surface (triangles by area), radius r.
inline Points random_points(const TriMesh& m, int32_t n, double r, uint64_t seed = 5) {
  std::vector<double> cumulative;
  double total = 0;
  for (int32_t t = 0; t < m.num_triangles(); ++t) {
    auto p0 = m.corner(t, 0), p1 = m.corner(t, 1), p2 = m.corner(t, 2);
    double a[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]}, b[3] = {p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]};
    double c[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
    total += 0.5 * std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    cumulative.push_back(total);
  }
  texsynth::Rng rng(seed);
  Points p;
  for (int32_t i = 0; i < n; ++i) {
    const double u = rng.uniform() * total;
    int32_t t = int32_t(std::upper_bound(cumulative.begin(), cumulative.end(), u) - cumulative.begin());
    if (t >= m.num_triangles()) t = m.num_triangles() - 1;
    double b1 = rng.uniform(), b2 = rng.uniform();
    if (b1 + b2 > 1) b1 = 1 - b1, b2 = 1 - b2;
    p.add(t, b1, b2, r);
  }
  return p;
}

}  // namespace ring_fixtures
