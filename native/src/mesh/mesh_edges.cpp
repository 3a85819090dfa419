// SPDX-License-Identifier: GPL-3.0-or-later
// Undirected edges of a mesh and the corners that use them (mesh_edges.hpp).
#include "texsynth/mesh/mesh_edges.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <utility>
#include <vector>

namespace texsynth {

MeshEdges build_mesh_edges(const Mesh& m) {
  // In parallel, with the serial definition's result: edge ids number the CSR slots (a -> b) with
  // a < b in order (so edges are sorted by (a, b)), and each edge lists its corners ascending.
  MeshEdges e;
  const int32_t V = m.num_vertices, L = m.num_corners;
  constexpr int32_t kGrain = 16384;
  std::vector<int32_t> first_edge(size_t(V) + 1, 0);  // edges owned by vertices < v
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, V, kGrain), [&](const tbb::blocked_range<int32_t>& r) {
    for (int32_t a = r.begin(); a < r.end(); ++a) {
      const int32_t* end = m.neighbours.data() + m.neighbour_start[a + 1];
      first_edge[a + 1] = int32_t(end - std::upper_bound(m.neighbours.data() + m.neighbour_start[a], end, a));
    }
  });
  for (int32_t a = 0; a < V; ++a) first_edge[a + 1] += first_edge[a];
  const int32_t E = first_edge[V];
  e.vertices.resize(size_t(E) * 2);
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, V, kGrain), [&](const tbb::blocked_range<int32_t>& r) {
    for (int32_t a = r.begin(); a < r.end(); ++a) {
      const int32_t* end = m.neighbours.data() + m.neighbour_start[a + 1];
      int32_t id = first_edge[a];
      for (const int32_t* b = end - (first_edge[a + 1] - first_edge[a]); b < end; ++b, ++id)
        e.vertices[2 * size_t(id)] = a, e.vertices[2 * size_t(id) + 1] = *b;
    }
  });
  e.corner_edge.resize(size_t(L));
  e.edge_corner_start.assign(size_t(E) + 1, 0);
  std::vector<std::atomic<int32_t>> count(static_cast<size_t>(E));
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, m.num_polys, kGrain / 4), [&](const tbb::blocked_range<int32_t>& r) {
    for (int32_t poly = r.begin(); poly < r.end(); ++poly) {
      const int32_t first = m.poly_starts[poly], n = m.poly_sizes[poly];
      for (int32_t i = 0; i < n; ++i) {
        const int32_t c = first + i;
        int32_t a = m.corner_verts[c], b = m.corner_verts[first + (i + 1) % n];
        e.corner_edge[c] = -1;
        if (a == b) continue;
        if (a > b) std::swap(a, b);
        const int32_t* begin = m.neighbours.data() + m.neighbour_start[a];
        const int32_t* end = m.neighbours.data() + m.neighbour_start[a + 1];
        // a's edges to larger neighbours are its last ones, numbered from first_edge[a].
        const int32_t id = first_edge[a + 1] - int32_t(end - std::lower_bound(begin, end, b));
        e.corner_edge[c] = id;
        count[id].fetch_add(1, std::memory_order_relaxed);
      }
    }
  });
  for (int32_t i = 0; i < E; ++i) e.edge_corner_start[i + 1] = e.edge_corner_start[i] + count[i].load(std::memory_order_relaxed);
  e.edge_corners.resize(size_t(e.edge_corner_start[E]));
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, E, kGrain), [&](const tbb::blocked_range<int32_t>& r) {
    for (int32_t i = r.begin(); i < r.end(); ++i) count[i].store(e.edge_corner_start[i], std::memory_order_relaxed);
  });
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, L, kGrain), [&](const tbb::blocked_range<int32_t>& r) {
    for (int32_t c = r.begin(); c < r.end(); ++c)
      if (e.corner_edge[c] >= 0) e.edge_corners[count[e.corner_edge[c]].fetch_add(1, std::memory_order_relaxed)] = c;
  });
  // Slots were taken in thread order: sort each edge's corners (usually 2) to ascending.
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, E, kGrain), [&](const tbb::blocked_range<int32_t>& r) {
    for (int32_t i = r.begin(); i < r.end(); ++i)
      std::sort(e.edge_corners.begin() + e.edge_corner_start[i], e.edge_corners.begin() + e.edge_corner_start[i + 1]);
  });
  return e;
}

}  // namespace texsynth
