// SPDX-License-Identifier: GPL-3.0-or-later
// §4.1 region-growing vertex order.
#include <atomic>
#include <cstddef>
#include <queue>

#include "texsynth/common/errors.hpp"
#include "texsynth/common/rng.hpp"
#include "texsynth/synth/jumpmap_synth.hpp"

namespace texsynth {
namespace {

// Seed of every component: its r-th vertex (in index order), r drawn from (seed, component id).
std::vector<int32_t> component_seeds(const Mesh& m, uint64_t seed) {
  using std::size_t;
  std::vector<int32_t> size(m.num_components, 0), pick(m.num_components), seen(m.num_components, 0), seeds(m.num_components, -1);
  for (int32_t v = 0; v < m.num_vertices; ++v)
    if (m.component[v] >= 0) ++size[m.component[v]];
  for (int32_t c = 0; c < m.num_components; ++c) pick[c] = int32_t(Rng(seed, uint64_t(c)).below(uint32_t(size[c])));
  for (int32_t v = 0; v < m.num_vertices; ++v) {
    int32_t c = m.component[v];
    if (c >= 0 && seen[c]++ == pick[c]) seeds[c] = v;
  }
  return seeds;
}

}  // namespace

namespace {

// The bucket-queue growth behind region_growing_order and its streaming form: calls
// begin_component() at each component's seed, then emit(v, ordered_neighbours) for each vertex in
// order, where bit k of ordered_neighbours is set when v's k-th neighbour (k < 32) came before v.
template <class BeginComponent, class Emit>
void grow_region_order(const Mesh& m, uint64_t seed, const std::atomic<bool>* cancel, BeginComponent&& begin_component,
                       Emit&& emit) {
  std::vector<int32_t> done_neighbours(m.num_vertices, 0);
  // Level of the vertex's live queue entry; -1 = not queued yet, kDone = ordered.
  constexpr signed char kDone = 127;
  std::vector<signed char> queued_level(m.num_vertices, -1);
  std::vector<int32_t> buckets[kOrderLevels + 1];
  // floor(done * levels / degree) without a division per edge: degree-indexed reciprocals. The
  // epsilon is far below the 1/degree gap between a fraction and the next integer.
  float reciprocal[256];
  for (int d = 1; d < 256; ++d) reciprocal[d] = float(kOrderLevels) / float(d);
  auto level = [&](int32_t v) {
    const int32_t degree = m.degree(v);
    return degree < 256 ? int32_t(float(done_neighbours[v]) * reciprocal[degree] + 1e-4f)
                        : int32_t((int64_t(done_neighbours[v]) * kOrderLevels) / degree);
  };
  size_t emitted = 0;
  for (int32_t start : component_seeds(m, seed)) {
    begin_component();
    int top = 0;
    buckets[0].push_back(start);
    queued_level[start] = 0;
    while (true) {
      while (top >= 0 && buckets[top].empty()) --top;
      if (top < 0) break;
      int32_t v = buckets[top].back();
      buckets[top].pop_back();
      // Stale entry: the vertex was raised to a higher level (it has a newer entry) or is done.
      if (queued_level[v] != top) continue;
      queued_level[v] = kDone;
      uint32_t ordered_neighbours = 0;
      for (int32_t k = m.neighbour_start[v]; k < m.neighbour_start[v + 1]; ++k) {
        int32_t w = m.neighbours[k];
        if (queued_level[w] == kDone) {
          if (k - m.neighbour_start[v] < 32) ordered_neighbours |= uint32_t(1) << (k - m.neighbour_start[v]);
          continue;
        }
        ++done_neighbours[w];
        const int32_t after = level(w);
        if (after != queued_level[w]) {
          queued_level[w] = static_cast<signed char>(after);
          buckets[after].push_back(w);
          if (after > top) top = after;
        }
      }
      emit(v, ordered_neighbours);
      if ((++emitted & 0xFFFF) == 0) throw_if_cancelled(cancel);
    }
  }
}

}  // namespace

VertexOrder region_growing_order(const Mesh& m, uint64_t seed, const std::atomic<bool>* cancel) {
  VertexOrder out;
  out.order.reserve(m.num_vertices);
  out.component_start.reserve(size_t(m.num_components) + 1);
  grow_region_order(
      m, seed, cancel, [&] { out.component_start.push_back(int32_t(out.order.size())); },
      [&](int32_t v, uint32_t) { out.order.push_back(v); });
  out.component_start.push_back(int32_t(out.order.size()));
  return out;
}

int32_t stream_region_growing_order(const Mesh& m, uint64_t seed, int32_t* out, uint32_t* ordered_neighbours,
                                    std::atomic<int32_t>& ready, const std::atomic<bool>* cancel) {
  int32_t count = 0;
  grow_region_order(m, seed, cancel, [] {}, [&](int32_t v, uint32_t ordered) {
    if (ordered_neighbours) ordered_neighbours[count] = ordered;
    out[count++] = v;
    if ((count & 1023) == 0) ready.store(count, std::memory_order_release);  // batched: one shared write per 1024
  });
  ready.store(count, std::memory_order_release);
  return count;
}

VertexOrder region_growing_order_heap(const Mesh& m, uint64_t seed, const std::atomic<bool>* cancel) {
  VertexOrder out;
  out.order.reserve(m.num_vertices);
  std::vector<int32_t> done_neighbours(m.num_vertices, 0);
  std::vector<char> done(m.num_vertices, 0);
  using Entry = std::pair<double, int32_t>;
  std::priority_queue<Entry> heap;
  for (int32_t start : component_seeds(m, seed)) {
    out.component_start.push_back(int32_t(out.order.size()));
    heap.push({0.0, start});
    while (!heap.empty()) {
      auto [proportion, v] = heap.top();
      heap.pop();
      if (done[v]) continue;
      if (m.degree(v) > 0 && proportion != double(done_neighbours[v]) / m.degree(v)) continue;  // stale
      done[v] = 1;
      out.order.push_back(v);
      if ((out.order.size() & 0xFFFF) == 0) throw_if_cancelled(cancel);
      for (int32_t k = m.neighbour_start[v]; k < m.neighbour_start[v + 1]; ++k) {
        int32_t w = m.neighbours[k];
        if (done[w]) continue;
        ++done_neighbours[w];
        heap.push({double(done_neighbours[w]) / m.degree(w), w});
      }
    }
  }
  out.component_start.push_back(int32_t(out.order.size()));
  return out;
}

}  // namespace texsynth
