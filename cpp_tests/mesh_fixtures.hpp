// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Test meshes in Blender layout, planted jump maps, and an independent per-face similarity check.
#include <array>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "texsynth/common/rng.hpp"
#include "texsynth/mesh/poly_mesh.hpp"
#include "texsynth/preprocess/preprocessed.hpp"

namespace fixtures {

struct TestMesh {
  std::vector<float> positions;
  std::vector<int32_t> corner_verts, poly_starts, poly_sizes;

  int32_t add_vertex(double x, double y, double z) {
    positions.insert(positions.end(), {float(x), float(y), float(z)});
    return int32_t(positions.size() / 3 - 1);
  }
  void add_poly(std::initializer_list<int32_t> verts) { add_poly(std::vector<int32_t>(verts)); }
  void add_poly(const std::vector<int32_t>& verts) {
    poly_starts.push_back(int32_t(corner_verts.size()));
    poly_sizes.push_back(int32_t(verts.size()));
    corner_verts.insert(corner_verts.end(), verts.begin(), verts.end());
  }
  texsynth::PolyMeshInput input() const {
    texsynth::PolyMeshInput in;
    in.positions = positions.data();
    in.num_vertices = int32_t(positions.size() / 3);
    in.corner_verts = corner_verts.data();
    in.num_corners = int32_t(corner_verts.size());
    in.poly_starts = poly_starts.data();
    in.poly_sizes = poly_sizes.data();
    in.num_polys = int32_t(poly_starts.size());
    return in;
  }
  int32_t num_vertices() const { return int32_t(positions.size() / 3); }
};

// (nx+1)*(ny+1) vertices on z = 0, counter-clockwise seen from +z. jitter in units of spacing.
inline TestMesh grid(int nx, int ny, double spacing, bool triangles, double jitter = 0.0, uint64_t seed = 1) {
  TestMesh m;
  texsynth::Rng rng(seed);
  for (int y = 0; y <= ny; ++y)
    for (int x = 0; x <= nx; ++x) {
      // One draw per statement: argument evaluation order differs between compilers (gcc: last first).
      const double dy = jitter * (rng.uniform() - 0.5);
      const double dx = jitter * (rng.uniform() - 0.5);
      m.add_vertex((x + dx) * spacing, (y + dy) * spacing, 0.0);
    }
  auto id = [&](int x, int y) { return int32_t(y * (nx + 1) + x); };
  for (int y = 0; y < ny; ++y)
    for (int x = 0; x < nx; ++x) {
      if (triangles) {
        m.add_poly({id(x, y), id(x + 1, y), id(x + 1, y + 1)});
        m.add_poly({id(x, y), id(x + 1, y + 1), id(x, y + 1)});
      } else {
        m.add_poly({id(x, y), id(x + 1, y), id(x + 1, y + 1), id(x, y + 1)});
      }
    }
  return m;
}

// UV sphere: planar quads between rings, triangle fans at the poles; outward-facing.
// noise > 0 moves vertices radially by up to ±noise·radius and splits quads into triangles
// (a "scanned" sphere: irregular, every face planar).
inline TestMesh uv_sphere(int rings, int segments, double radius, double noise = 0.0, uint64_t seed = 3) {
  TestMesh m;
  texsynth::Rng rng(seed);
  auto r = [&]() { return radius * (1.0 + (noise > 0 ? noise * (2 * rng.uniform() - 1) : 0.0)); };
  const double pi = 3.14159265358979323846;
  int32_t south = m.add_vertex(0, 0, -r());
  for (int i = 1; i < rings; ++i) {
    double th = pi * i / rings - pi / 2;
    for (int j = 0; j < segments; ++j) {
      double ph = 2 * pi * j / segments, rr = r();
      m.add_vertex(rr * std::cos(th) * std::cos(ph), rr * std::cos(th) * std::sin(ph), rr * std::sin(th));
    }
  }
  int32_t north = m.add_vertex(0, 0, r());
  auto id = [&](int ring, int seg) { return int32_t(1 + (ring - 1) * segments + (seg % segments)); };
  for (int j = 0; j < segments; ++j) m.add_poly({south, id(1, j + 1), id(1, j)});
  for (int i = 1; i + 1 < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      int32_t a = id(i, j), b = id(i, j + 1), c = id(i + 1, j + 1), d = id(i + 1, j);
      if (noise > 0) {
        m.add_poly({a, b, c});
        m.add_poly({a, c, d});
      } else {
        m.add_poly({a, b, c, d});
      }
    }
  for (int j = 0; j < segments; ++j) m.add_poly({id(rings - 1, j), id(rings - 1, j + 1), north});
  return m;
}

// Vertex indices permuted and polygons shuffled: an order unrelated to the surface, as after some
// importers and subdivisions. With rotate_corners each polygon's corner cycle starts at a random
// corner (same cycle), else at its first.
inline TestMesh shuffled(const TestMesh& t, uint64_t seed, bool rotate_corners = true) {
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
  std::vector<int32_t> verts;
  for (int32_t p : poly_order) {
    const int32_t n = t.poly_sizes[p], start = rotate_corners ? int32_t(rng.below(uint32_t(n))) : 0;
    verts.clear();
    for (int32_t i = 0; i < n; ++i) verts.push_back(new_index[t.corner_verts[t.poly_starts[p] + (start + i) % n]]);
    out.add_poly(verts);
  }
  return out;
}

// Jittered quads, triangles of a noisy sphere and a strip of hexagons (n-gons: n > 4 sets).
inline TestMesh mixed_mesh() {
  TestMesh m = grid(70, 60, 1.0, false, 0.35, 9);
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
  append(uv_sphere(30, 50, 8.0, 0.05), 100.0);
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

// A jump map with k jumps per pixel to random targets inside [margin, size - margin), equal weights
// summing to weight_sum.
inline texsynth::Preprocessed planted(int width, int height, int k, float weight_sum, bool tileable, int margin = 0,
                                      uint64_t seed = 11) {
  texsynth::Preprocessed pre;
  pre.width = width;
  pre.height = height;
  pre.params.tileable = tileable;
  pre.jump_map.k = k;
  texsynth::Rng rng(seed);
  for (int p = 0; p < width * height; ++p)
    for (int s = 0; s < k; ++s) {
      int x = margin + int(rng.below(uint32_t(width - 2 * margin)));
      int y = margin + int(rng.below(uint32_t(height - 2 * margin)));
      pre.jump_map.targets.push_back(y * width + x);
      pre.jump_map.weights.push_back(weight_sum / k);
    }
  return pre;
}

// Linear map from a triangle's own plane to texel space, from positions and Blender UVs only.
// Returns false for degenerate triangles. Basis (e1, e2, n) right-handed with n = (p1-p0)×(p2-p0).
struct FaceMap {
  double J[2][2];         // texel = J · (local 2D)
  std::array<double, 3> e1, e2;
};
inline bool face_map(const std::array<std::array<double, 3>, 3>& p, const std::array<std::array<double, 2>, 3>& uv,
                     double width, double height, FaceMap& out) {
  auto sub = [](auto a, auto b) { return std::array<double, 3>{a[0] - b[0], a[1] - b[1], a[2] - b[2]}; };
  auto dotp = [](auto a, auto b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; };
  auto crossp = [](auto a, auto b) {
    return std::array<double, 3>{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
  };
  auto a = sub(p[1], p[0]), b = sub(p[2], p[0]);
  auto n = crossp(a, b);
  double la = std::sqrt(dotp(a, a)), ln = std::sqrt(dotp(n, n));
  if (la < 1e-12 || ln < 1e-18) return false;
  for (auto& c : a) c /= la;
  for (auto& c : n) c /= ln;
  out.e1 = a;
  out.e2 = crossp(n, a);
  // local coords of p1 - p0 and p2 - p0
  auto P1 = sub(p[1], p[0]), P2 = sub(p[2], p[0]);
  double M[2][2] = {{dotp(P1, out.e1), dotp(P2, out.e1)}, {dotp(P1, out.e2), dotp(P2, out.e2)}};
  auto tex = [&](int i) { return std::array<double, 2>{uv[i][0] * width, (1.0 - uv[i][1]) * height}; };
  auto t0 = tex(0), t1 = tex(1), t2 = tex(2);
  double T[2][2] = {{t1[0] - t0[0], t2[0] - t0[0]}, {t1[1] - t0[1], t2[1] - t0[1]}};
  double det = M[0][0] * M[1][1] - M[0][1] * M[1][0];
  double Mi[2][2] = {{M[1][1] / det, -M[0][1] / det}, {-M[1][0] / det, M[0][0] / det}};
  for (int r = 0; r < 2; ++r)
    for (int c = 0; c < 2; ++c) out.J[r][c] = T[r][0] * Mi[0][c] + T[r][1] * Mi[1][c];
  return true;
}

// Singular values of a 2×2 matrix (closed form).
inline std::array<double, 2> singular_values(const double J[2][2]) {
  double a = J[0][0], b = J[0][1], c = J[1][0], d = J[1][1];
  double s1 = a * a + b * b + c * c + d * d;
  double s2 = std::sqrt((a * a + b * b - c * c - d * d) * (a * a + b * b - c * c - d * d) + 4 * (a * c + b * d) * (a * c + b * d));
  return {std::sqrt(std::max(0.0, (s1 + s2) / 2)), std::sqrt(std::max(0.0, (s1 - s2) / 2))};
}

// The 3D unit direction that the map sends to texel (0, -1), i.e. texture "up".
inline std::array<double, 3> texture_up_direction(const FaceMap& f) {
  double det = f.J[0][0] * f.J[1][1] - f.J[0][1] * f.J[1][0];
  // solve J · a = (0, -1)
  double a0 = (f.J[0][1] * 1.0) / det, a1 = (-f.J[0][0] * 1.0) / det;
  std::array<double, 3> d{a0 * f.e1[0] + a1 * f.e2[0], a0 * f.e1[1] + a1 * f.e2[1], a0 * f.e1[2] + a1 * f.e2[2]};
  double l = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  for (auto& c : d) c /= l;
  return d;
}

}  // namespace fixtures
