// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/field/curvature.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

#include "texsynth/mesh/vec_math.hpp"

namespace texsynth {
namespace {

using Tensor = std::array<double, 6>;  // symmetric 3×3: xx, xy, xz, yy, yz, zz

template <class F>
void parallel_vertices(int32_t n, F&& f) {
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, n, 4096), [&](const tbb::blocked_range<int32_t>& r) {
    for (int32_t v = r.begin(); v < r.end(); ++v) f(v);
  });
}

V3 tensor_times(const Tensor& t, V3 a) {
  return {t[0] * a.x + t[1] * a.y + t[2] * a.z, t[1] * a.x + t[3] * a.y + t[4] * a.z,
          t[2] * a.x + t[4] * a.y + t[5] * a.z};
}

// Tangent frame (e1, e2) of unit normal n.
void frame(V3 n, V3& e1, V3& e2) {
  e1 = any_perpendicular(n);
  e2 = cross(n, e1);
}

}  // namespace

CurvatureResult principal_curvature_directions(const Mesh& m, const CurvatureParams& p) {
  if (p.smoothing_rings < 0 || p.smoothing_rings > 1000) throw std::invalid_argument("smoothing_rings must be in [0, 1000]");
  if (!(p.anisotropy_threshold >= 0 && p.anisotropy_threshold <= 1))
    throw std::invalid_argument("anisotropy_threshold must be in [0, 1]");
  const int32_t nv = m.num_vertices;
  auto normal = [&](int32_t v) { return v3(&m.normals[3 * size_t(v)]); };
  auto position = [&](int32_t v) { return v3(m.positions + 3 * size_t(v)); };

  // Vertices sharing a polygon with v (edges AND diagonals): on quad meshes the edges alone give
  // only two directions, too few to fix the three coefficients of the curvature form.
  std::vector<int32_t> poly_start(size_t(nv) + 1, 0), vertex_polys;
  for (int32_t c = 0; c < m.num_corners; ++c) ++poly_start[size_t(m.corner_verts[c]) + 1];
  for (int32_t v = 0; v < nv; ++v) poly_start[v + 1] += poly_start[v];
  vertex_polys.resize(size_t(m.num_corners));
  {
    std::vector<int32_t> fill(poly_start.begin(), poly_start.end() - 1);
    for (int32_t p = 0; p < m.num_polys; ++p)
      for (int32_t k = 0; k < m.poly_sizes[p]; ++k) vertex_polys[fill[m.corner_verts[m.poly_starts[p] + k]]++] = p;
  }
  constexpr int32_t kMaxRingPolySize = 16;  // larger n-gons contribute their edges only

  // --- per-vertex least-squares fit of k(t) = a x² + 2 b x y + c y² over directions t = (x, y)
  std::vector<Tensor> tensor(nv, Tensor{});
  parallel_vertices(nv, [&](int32_t v) {
    V3 n = normal(v), e1, e2;
    frame(n, e1, e2);
    double ata[3][3] = {}, atb[3] = {};
    std::vector<int32_t> ring(m.neighbours.begin() + m.neighbour_start[v], m.neighbours.begin() + m.neighbour_start[v + 1]);
    for (int32_t i = poly_start[v]; i < poly_start[v + 1]; ++i) {
      const int32_t p = vertex_polys[i];
      if (m.poly_sizes[p] > kMaxRingPolySize) continue;
      for (int32_t k = 0; k < m.poly_sizes[p]; ++k) ring.push_back(m.corner_verts[m.poly_starts[p] + k]);
    }
    std::sort(ring.begin(), ring.end());
    ring.erase(std::unique(ring.begin(), ring.end()), ring.end());
    for (int32_t w : ring) {
      if (w == v) continue;
      V3 e = position(w) - position(v);
      double len2 = dot(e, e);
      V3 t = project_to_plane(e, n);
      double tl = norm(t);
      if (len2 < 1e-30 || tl < 1e-15) continue;
      double kappa = -2.0 * dot(n, e) / len2;
      double x = dot(t, e1) / tl, y = dot(t, e2) / tl;
      double row[3] = {x * x, 2 * x * y, y * y};
      for (int i = 0; i < 3; ++i) {
        atb[i] += row[i] * kappa;
        for (int j = 0; j < 3; ++j) ata[i][j] += row[i] * row[j];
      }
    }
    // A small ridge term keeps the fit defined when the one-ring has only two edge directions
    // (quad grids: the cross term is then unconstrained and goes to 0). Solve by Cramer's rule.
    const double ridge = 1e-3 * (ata[0][0] + ata[1][1] + ata[2][2]) / 3.0;
    for (int i = 0; i < 3; ++i) ata[i][i] += ridge;
    double det = ata[0][0] * (ata[1][1] * ata[2][2] - ata[1][2] * ata[2][1]) -
                 ata[0][1] * (ata[1][0] * ata[2][2] - ata[1][2] * ata[2][0]) +
                 ata[0][2] * (ata[1][0] * ata[2][1] - ata[1][1] * ata[2][0]);
    if (!(std::fabs(det) > 1e-30)) return;  // no usable edge at all
    double sol[3];
    for (int c = 0; c < 3; ++c) {
      double a[3][3];
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) a[i][j] = j == c ? atb[i] : ata[i][j];
      sol[c] = (a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
                a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])) / det;
    }
    if (!std::isfinite(sol[0]) || !std::isfinite(sol[1]) || !std::isfinite(sol[2])) return;
    // 3D tensor S = a e1e1ᵀ + b (e1e2ᵀ + e2e1ᵀ) + c e2e2ᵀ
    const double a = sol[0], b = sol[1], c = sol[2];
    auto outer = [](V3 u, V3 w) {
      return Tensor{u.x * w.x, 0.5 * (u.x * w.y + u.y * w.x), 0.5 * (u.x * w.z + u.z * w.x), u.y * w.y,
                    0.5 * (u.y * w.z + u.z * w.y), u.z * w.z};
    };
    Tensor t11 = outer(e1, e1), t12 = outer(e1, e2), t22 = outer(e2, e2);
    for (int i = 0; i < 6; ++i) tensor[v][i] = a * t11[i] + 2 * b * t12[i] + c * t22[i];
  });

  // --- one-ring averaging (Jacobi, order-independent)
  std::vector<Tensor> next(nv);
  for (int it = 0; it < p.smoothing_rings; ++it) {
    parallel_vertices(nv, [&](int32_t v) {
      Tensor sum = tensor[v];
      for (int32_t k = m.neighbour_start[v]; k < m.neighbour_start[v + 1]; ++k)
        for (int i = 0; i < 6; ++i) sum[i] += tensor[m.neighbours[k]][i];
      const double w = 1.0 / double(m.degree(v) + 1);
      for (int i = 0; i < 6; ++i) next[v][i] = sum[i] * w;
    });
    tensor.swap(next);
  }

  // --- eigen-decomposition of the tensor restricted to each tangent plane
  CurvatureResult out;
  out.min_direction.assign(3 * size_t(nv), 0.f);
  out.curvatures.assign(2 * size_t(nv), 0.f);
  parallel_vertices(nv, [&](int32_t v) {
    V3 n = normal(v), e1, e2;
    frame(n, e1, e2);
    const double a = dot(e1, tensor_times(tensor[v], e1)), b = dot(e1, tensor_times(tensor[v], e2)), c = dot(e2, tensor_times(tensor[v], e2));
    const double mean = 0.5 * (a + c), radius = std::sqrt(0.25 * (a - c) * (a - c) + b * b);
    const double k_hi = mean + radius, k_lo = mean - radius;
    const bool lo_flat = std::fabs(k_lo) <= std::fabs(k_hi);
    const double k_flat = lo_flat ? k_lo : k_hi, k_steep = lo_flat ? k_hi : k_lo;
    out.curvatures[2 * size_t(v)] = float(k_flat);
    out.curvatures[2 * size_t(v) + 1] = float(k_steep);
    const double biggest = std::fabs(k_steep);
    if (!(biggest > 1e-12) || std::fabs(k_steep) - std::fabs(k_flat) < p.anisotropy_threshold * biggest) return;
    // Eigenvector of [[a, b], [b, c]] for eigenvalue k_flat.
    double x = b, y = k_flat - a;
    if (std::fabs(a - k_flat) + std::fabs(b) < std::fabs(c - k_flat) + std::fabs(b)) x = k_flat - c, y = b;
    V3 d = normalized_or(e1 * x + e2 * y, V3{});
    if (norm(d) == 0) return;
    store(&out.min_direction[3 * size_t(v)], d);
  });

  // --- consistent signs: breadth-first per component, each defined direction flipped to agree
  // with the reference carried from its parent (lowest vertex id first: deterministic).
  std::vector<char> seen(nv, 0);
  std::vector<float> reference(3 * size_t(nv), 0.f);
  std::vector<int32_t> queue;
  queue.reserve(nv);
  for (int32_t root = 0; root < nv; ++root) {
    if (seen[root]) continue;
    seen[root] = 1;
    V3 d0 = v3(&out.min_direction[3 * size_t(root)]);
    store(&reference[3 * size_t(root)], norm(d0) > 0 ? d0 : any_perpendicular(normal(root)));
    queue.assign(1, root);
    for (size_t head = 0; head < queue.size(); ++head) {
      const int32_t v = queue[head];
      const V3 ref_v = v3(&reference[3 * size_t(v)]);
      for (int32_t k = m.neighbour_start[v]; k < m.neighbour_start[v + 1]; ++k) {
        const int32_t w = m.neighbours[k];
        if (seen[w]) continue;
        seen[w] = 1;
        float* d = &out.min_direction[3 * size_t(w)];
        V3 dw = v3(d);
        V3 carried = normalized_or(project_to_plane(ref_v, normal(w)), ref_v);
        if (norm(dw) > 0) {
          if (dot(dw, carried) < 0) dw = dw * -1.0, store(d, dw);
          store(&reference[3 * size_t(w)], dw);
        } else {
          store(&reference[3 * size_t(w)], carried);
        }
        queue.push_back(w);
      }
    }
  }
  return out;
}

}  // namespace texsynth
