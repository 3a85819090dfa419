// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/mesh/walk_mesh.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "texsynth/common/errors.hpp"

namespace texsynth {
namespace {

// Exactly coincident positions share one representative (the smallest index), so meshes split at UV
// seams or imported with split vertices still connect. Exact float equality (0 == -0): welding by a
// distance would merge genuinely separate surfaces and needs a scale we do not have.
std::vector<int32_t> weld_positions(const TriangleMeshInput& m, const std::atomic<bool>* cancel) {
  const int32_t nv = m.num_vertices;
  std::vector<int32_t> order(static_cast<size_t>(nv));
  std::iota(order.begin(), order.end(), 0);
  // A total order (index breaks ties), so the result does not depend on the sort's scheduling.
  tbb::parallel_sort(order.begin(), order.end(), [&](int32_t a, int32_t b) {
    const float *pa = m.positions + 3 * size_t(a), *pb = m.positions + 3 * size_t(b);
    for (int k = 0; k < 3; ++k)
      if (pa[k] != pb[k]) return pa[k] < pb[k];
    return a < b;
  });
  throw_if_cancelled(cancel);
  std::vector<int32_t> weld(static_cast<size_t>(nv));
  int32_t rep = -1;
  for (int32_t i = 0; i < nv; ++i) {
    const int32_t v = order[i];
    if (i == 0) {
      rep = v;
    } else {
      const float *pa = m.positions + 3 * size_t(v), *pb = m.positions + 3 * size_t(order[i - 1]);
      if (pa[0] != pb[0] || pa[1] != pb[1] || pa[2] != pb[2]) rep = v;
    }
    weld[v] = rep;
  }
  return weld;
}

void build_triangle_geometry(const TriangleMeshInput& m, WalkMesh& w, const std::atomic<bool>* cancel) {
  w.tris.resize(size_t(m.num_triangles));
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, m.num_triangles, 4096), [&](const tbb::blocked_range<int32_t>& r) {
    throw_if_cancelled(cancel);
    for (int32_t t = r.begin(); t < r.end(); ++t) {
    const int32_t* c = m.triangles + 3 * size_t(t);
    const V3 p0 = mesh_position(m, c[0]), e1 = mesh_position(m, c[1]) - p0, e2 = mesh_position(m, c[2]) - p0;
    const V3 e3 = e2 - e1;
    const V3 n = cross(e1, e2);
    const double n2 = dot(n, n), longest2 = std::max({dot(e1, e1), dot(e2, e2), dot(e3, e3)});
    WalkTriangle& wt = w.tris[t];
    wt.degenerate = !(std::sqrt(n2) > kDegenerateRelativeArea * longest2) || !std::isfinite(n2);
    if (wt.degenerate) continue;
    // ∇β1 = (e2 × n)/|n|², ∇β2 = (n × e1)/|n|²: ∇β1·e1 = 1, ∇β1·e2 = 0 and likewise for β2.
    wt.grad1 = cross(e2, n) * (1.0 / n2);
    wt.grad2 = cross(n, e1) * (1.0 / n2);
    wt.normal = n * (1.0 / std::sqrt(n2));
    wt.inv_edge = {1 / norm(e1), 1 / norm(e3), 1 / norm(e2)};  // edges 0->1, 1->2, 2->0
    }
  });
}

// Area-weighted normals of the welded mesh, summed serially in triangle order: the same doubles for
// any thread count, and cheap next to the walks.
void build_vertex_normals(const TriangleMeshInput& m, WalkMesh& w) {
  w.vertex_normal.assign(size_t(m.num_vertices), V3{});
  for (int32_t t = 0; t < m.num_triangles; ++t) {
    const int32_t* c = m.triangles + 3 * size_t(t);
    const V3 p0 = mesh_position(m, c[0]);
    const V3 n = cross(mesh_position(m, c[1]) - p0, mesh_position(m, c[2]) - p0);  // 2 × area × unit normal
    for (int k = 0; k < 3; ++k) {
      V3& acc = w.vertex_normal[w.weld[c[k]]];
      acc = acc + n;
    }
  }
  for (V3& n : w.vertex_normal) n = normalized_or(n, V3{}, 1e-300);
}

// Edges shared by exactly two non-degenerate triangles that traverse them in opposite directions
// (consistent orientation: the facing test and the counter-clockwise sense need it) connect; every
// other edge stops a walk. Half-edges are keyed by welded endpoints and sorted with a total order.
void link_edges(const TriangleMeshInput& m, WalkMesh& w, const std::atomic<bool>* cancel) {
  struct HalfEdge {
    uint64_t key;
    int32_t id;  // 3 × triangle + edge
  };
  std::vector<HalfEdge> half;
  half.reserve(3 * size_t(m.num_triangles));
  for (int32_t t = 0; t < m.num_triangles; ++t)
    for (int k = 0; k < 3; ++k) {
      const int32_t a = w.weld[m.triangles[3 * size_t(t) + k]], b = w.weld[m.triangles[3 * size_t(t) + (k + 1) % 3]];
      if (a == b) continue;  // collapsed edge: its triangle is degenerate anyway
      half.push_back({(uint64_t(uint32_t(std::min(a, b))) << 32) | uint32_t(std::max(a, b)), 3 * t + k});
    }
  tbb::parallel_sort(half.begin(), half.end(), [](const HalfEdge& x, const HalfEdge& y) {
    return x.key != y.key ? x.key < y.key : x.id < y.id;
  });
  throw_if_cancelled(cancel);
  auto from = [&](int32_t id) { return w.weld[m.triangles[size_t(id)]]; };
  for (size_t s = 0; s < half.size();) {
    size_t e = s + 1;
    while (e < half.size() && half[e].key == half[s].key) ++e;
    if (e - s == 2) {
      const int32_t h0 = half[s].id, h1 = half[s + 1].id, t0 = h0 / 3, t1 = h1 / 3;
      if (t0 != t1 && from(h0) != from(h1) && !w.tris[t0].degenerate && !w.tris[t1].degenerate) {
        w.tris[t0].across[h0 % 3] = (t1 << 2) | (h1 % 3);
        w.tris[t1].across[h1 % 3] = (t0 << 2) | (h0 % 3);
      }
    }
    s = e;
  }
}

}  // namespace

WalkMesh build_walk_mesh(const TriangleMeshInput& mesh, const std::atomic<bool>* cancel) {
  WalkMesh w;
  w.weld = weld_positions(mesh, cancel);
  build_triangle_geometry(mesh, w, cancel);
  build_vertex_normals(mesh, w);
  link_edges(mesh, w, cancel);
  return w;
}

int64_t walk_mesh_peak_bytes(int64_t num_triangles, int64_t num_vertices) {
  // Per triangle its WalkTriangle plus the half-edge sort (3 × 16 B, freed before any walk, counted
  // anyway); per vertex the weld map, its sort order and the normal.
  return num_triangles * int64_t(sizeof(WalkTriangle) + 48) + num_vertices * int64_t(2 * sizeof(int32_t) + sizeof(V3));
}

}  // namespace texsynth
