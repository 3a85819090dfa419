// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/mesh/mesh.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>

#include "texsynth/common/errors.hpp"
#include "texsynth/common/threads.hpp"
#include "texsynth/common/uninitialized_vector.hpp"
#include "texsynth/mesh/vec_math.hpp"

namespace texsynth {
namespace {

void validate(const PolyMeshInput& in, const float* normals) {
  if (in.num_vertices < 0 || in.num_corners < 0 || in.num_polys < 0)
    throw std::invalid_argument("mesh: negative vertex, corner or polygon count");
  if ((in.num_vertices > 0 && !in.positions) || (in.num_corners > 0 && !in.corner_verts) ||
      (in.num_polys > 0 && (!in.poly_starts || !in.poly_sizes)))
    throw std::invalid_argument("mesh: missing positions, corner_verts, poly_starts or poly_sizes data");
  // Two directed half-edges per corner must fit the int32 CSR offsets.
  if (in.num_corners > std::numeric_limits<int32_t>::max() / 2)
    throw std::invalid_argument("mesh: too many corners (" + std::to_string(in.num_corners) + ")");
  for (int64_t i = 0; i < int64_t(in.num_vertices) * 3; ++i)
    if (!std::isfinite(in.positions[i]))
      throw std::invalid_argument("mesh: position of vertex " + std::to_string(i / 3) + " is NaN or infinite");
  if (normals)
    for (int64_t i = 0; i < int64_t(in.num_vertices) * 3; ++i)
      if (!std::isfinite(normals[i]))
        throw std::invalid_argument("mesh: normal of vertex " + std::to_string(i / 3) + " is NaN or infinite");
  int64_t expected_start = 0;
  for (int32_t p = 0; p < in.num_polys; ++p) {
    if (in.poly_sizes[p] < 3)
      throw std::invalid_argument("mesh: polygon " + std::to_string(p) + " has " + std::to_string(in.poly_sizes[p]) +
                                  " corners (need at least 3)");
    if (in.poly_starts[p] != expected_start)
      throw std::invalid_argument("mesh: poly_starts[" + std::to_string(p) + "] = " + std::to_string(in.poly_starts[p]) +
                                  " but polygons must be contiguous (expected " + std::to_string(expected_start) + ")");
    expected_start += in.poly_sizes[p];
    if (expected_start > in.num_corners)
      throw std::invalid_argument("mesh: polygon " + std::to_string(p) + " runs past the last corner (" +
                                  std::to_string(in.num_corners) + " corners)");
  }
  if (expected_start != in.num_corners)
    throw std::invalid_argument("mesh: polygons cover " + std::to_string(expected_start) + " corners but corner_verts has " +
                                std::to_string(in.num_corners));
  for (int32_t c = 0; c < in.num_corners; ++c)
    if (in.corner_verts[c] < 0 || in.corner_verts[c] >= in.num_vertices)
      throw std::invalid_argument("mesh: corner " + std::to_string(c) + " references vertex " +
                                  std::to_string(in.corner_verts[c]) + " (mesh has " + std::to_string(in.num_vertices) +
                                  " vertices)");
}

template <class F>
void parallel_range(int32_t n, int32_t grain, const std::atomic<bool>* cancel, F&& f) {
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, n, grain), [&](const tbb::blocked_range<int32_t>& r) {
    throw_if_cancelled(cancel);
    for (int32_t i = r.begin(); i < r.end(); ++i) f(i);
  });
}

// corner_poly (parallel per polygon) and the vertex -> corners CSR, a counting sort over contiguous
// polygon blocks in parallel: block b's corners of v go after those of blocks < b, so each vertex's
// corners are in ascending order whatever the number of blocks or threads. The same scatter puts
// each corner's polygon neighbours (previous and next vertex) next to it in `corner_ring`, so the
// one-rings are built from contiguous runs instead of three dependent look-ups per corner.
void build_corner_tables(Mesh& m, UninitializedVector<int32_t>& corner_ring, const std::atomic<bool>* cancel) {
  const int32_t nv = m.num_vertices, nc = m.num_corners, np = m.num_polys;
  m.corner_poly.resize(size_t(nc));
  parallel_range(np, 4096, cancel, [&](int32_t p) {
    std::fill_n(m.corner_poly.begin() + m.poly_starts[p], m.poly_sizes[p], p);
  });
  // Few blocks: each costs a per-vertex counter array.
  const int blocks = std::clamp(usable_threads(), 1, 4);
  auto first_poly = [&](int b) { return int32_t(int64_t(np) * b / blocks); };
  auto first_corner = [&](int b) { return first_poly(b) < np ? m.poly_starts[first_poly(b)] : nc; };
  std::vector<UninitializedVector<int32_t>> next_slot(blocks);  // per block and vertex: count, then slot
  tbb::parallel_for(0, blocks, [&](int b) {
    throw_if_cancelled(cancel);
    next_slot[b].assign(size_t(nv), 0);
    for (int32_t c = first_corner(b); c < first_corner(b + 1); ++c) ++next_slot[b][m.corner_verts[c]];
  });
  throw_if_cancelled(cancel);
  m.vertex_corner_start.resize(size_t(nv) + 1);
  m.vertex_corner_start[0] = 0;
  for (int32_t v = 0, start = 0; v < nv; ++v) {
    for (int b = 0; b < blocks; ++b) {
      const int32_t count = next_slot[b][v];
      next_slot[b][v] = start;
      start += count;
    }
    m.vertex_corner_start[v + 1] = start;
  }
  m.vertex_corners.resize(size_t(nc));
  corner_ring.resize(2 * size_t(nc));
  tbb::parallel_for(0, blocks, [&](int b) {
    throw_if_cancelled(cancel);
    int32_t* slots = next_slot[b].data();
    for (int32_t p = first_poly(b); p < first_poly(b + 1); ++p) {
      const int32_t first = m.poly_starts[p], n = m.poly_sizes[p];
      const int32_t* cv = m.corner_verts + first;
      for (int32_t i = 0; i < n; ++i) {
        const int32_t slot = slots[cv[i]]++;
        m.vertex_corners[slot] = first + i;
        corner_ring[2 * size_t(slot)] = cv[i == 0 ? n - 1 : i - 1];
        corner_ring[2 * size_t(slot) + 1] = cv[i + 1 == n ? 0 : i + 1];
      }
    }
  });
}

// Distinct neighbours of each vertex, sorted: its corners' polygon neighbours (corner_ring) minus
// itself. Sorted and deduplicated in place (one parallel pass), then packed into the CSR.
void build_one_rings(Mesh& m, UninitializedVector<int32_t>& corner_ring, const std::atomic<bool>* cancel) {
  const int32_t nv = m.num_vertices;
  m.neighbour_start.resize(size_t(nv) + 1);
  m.neighbour_start[0] = 0;
  parallel_range(nv, 4096, cancel, [&](int32_t v) {
    int32_t* b = corner_ring.data() + 2 * size_t(m.vertex_corner_start[v]);
    int32_t* e = std::remove(b, corner_ring.data() + 2 * size_t(m.vertex_corner_start[v + 1]), v);
    std::sort(b, e);
    m.neighbour_start[v + 1] = int32_t(std::unique(b, e) - b);
  });
  for (int32_t v = 0; v < nv; ++v) m.neighbour_start[v + 1] += m.neighbour_start[v];
  m.neighbours.resize(m.neighbour_start[nv]);
  parallel_range(nv, 4096, cancel, [&](int32_t v) {
    std::copy_n(corner_ring.data() + 2 * size_t(m.vertex_corner_start[v]), m.degree(v),
                m.neighbours.begin() + m.neighbour_start[v]);
  });
}

void build_normals(Mesh& m, const float* given, const std::atomic<bool>* cancel) {
  const int32_t nv = m.num_vertices;
  // Newell's vector = 2 × area × unit normal: summing it weights faces by area.
  UninitializedVector<V3> newell(size_t(m.num_polys));
  parallel_range(m.num_polys, 4096, cancel, [&](int32_t p) {
    newell[p] = newell_vector(m.positions, m.corner_verts + m.poly_starts[p], m.poly_sizes[p]);
  });
  m.normals.resize(size_t(nv) * 3);
  parallel_range(nv, 4096, cancel, [&](int32_t v) {
    V3 acc;  // summed in ascending corner order: the same doubles whatever the thread count
    for (int32_t k = m.vertex_corner_start[v]; k < m.vertex_corner_start[v + 1]; ++k) {
      const V3& n = newell[m.corner_poly[m.vertex_corners[k]]];
      acc.x += n.x, acc.y += n.y, acc.z += n.z;
    }
    V3 computed = normalized_or(acc, V3{0, 0, 1}, 1e-30);
    V3 nrm = given ? normalized_or(v3(given + 3 * size_t(v)), computed, 1e-30) : computed;
    store(&m.normals[3 * size_t(v)], nrm);
  });
}

// Connected components by a lock-free union-find over the edges (a root is always linked under a
// smaller one, so every root is its component's lowest vertex), then numbered by that vertex:
// the ids a serial search from each lowest unvisited vertex would give, whatever the thread count.
void build_components(Mesh& m, const std::atomic<bool>* cancel) {
  const int32_t nv = m.num_vertices;
  std::unique_ptr<std::atomic<int32_t>[]> parent(new std::atomic<int32_t>[size_t(nv)]);
  std::vector<char> used(size_t(nv), 0);
  parallel_range(nv, 16384, cancel, [&](int32_t v) { parent[v].store(v, std::memory_order_relaxed); });
  for (int32_t c = 0; c < m.num_corners; ++c) used[m.corner_verts[c]] = 1;
  auto find = [&](int32_t x) {  // with path halving: parents only ever move to ancestors
    while (true) {
      int32_t p = parent[x].load(std::memory_order_relaxed);
      if (p == x) return x;
      const int32_t grandparent = parent[p].load(std::memory_order_relaxed);
      if (grandparent != p) parent[x].compare_exchange_weak(p, grandparent, std::memory_order_relaxed);
      x = grandparent;
    }
  };
  parallel_range(nv, 4096, cancel, [&](int32_t v) {
    for (int32_t k = m.neighbour_start[v]; k < m.neighbour_start[v + 1]; ++k) {
      int32_t a = v, b = m.neighbours[k];
      if (b < a) continue;  // each edge once
      while (true) {
        a = find(a), b = find(b);
        if (a == b) break;
        if (a < b) std::swap(a, b);
        int32_t expected = a;  // link root a under the smaller root b, unless a was linked meanwhile
        if (parent[a].compare_exchange_strong(expected, b, std::memory_order_relaxed)) break;
      }
    }
  });
  throw_if_cancelled(cancel);
  m.component.resize(size_t(nv));
  parallel_range(nv, 16384, cancel, [&](int32_t v) { m.component[v] = used[v] ? find(v) : -1; });
  int32_t id = 0;
  std::vector<int32_t> root_id(size_t(nv), -1);
  for (int32_t v = 0; v < nv; ++v)
    if (m.component[v] == v) root_id[v] = id++;
  parallel_range(nv, 16384, cancel, [&](int32_t v) {
    if (m.component[v] >= 0) m.component[v] = root_id[m.component[v]];
  });
  m.num_components = id;
}

}  // namespace

bool Mesh::all_triangles() const {
  for (int32_t p = 0; p < num_polys; ++p)
    if (poly_sizes[p] != 3) return false;
  return true;
}

int32_t Mesh::max_poly_size() const {
  int32_t best = 0;
  for (int32_t p = 0; p < num_polys; ++p) best = std::max(best, poly_sizes[p]);
  return best;
}

Mesh build_mesh(const PolyMeshInput& in, const float* normals, const std::atomic<bool>* cancel) {
  validate(in, normals);
  throw_if_cancelled(cancel);
  Mesh m;
  m.num_vertices = in.num_vertices;
  m.num_corners = in.num_corners;
  m.num_polys = in.num_polys;
  m.positions = in.positions;
  m.corner_verts = in.corner_verts;
  m.poly_starts = in.poly_starts;
  m.poly_sizes = in.poly_sizes;
  {
    UninitializedVector<int32_t> corner_ring;  // 2 per corner, dropped once the one-rings are packed
    build_corner_tables(m, corner_ring, cancel);
    build_one_rings(m, corner_ring, cancel);
  }
  throw_if_cancelled(cancel);
  // Independent (different outputs).
  tbb::parallel_invoke([&] { build_normals(m, normals, cancel); }, [&] { build_components(m, cancel); });
  return m;
}

}  // namespace texsynth
