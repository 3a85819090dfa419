// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Internal to the patches module: what exemplar_cache.cpp needs from exemplar_index.cpp without
// including hnswlib (its header defines non-inline functions, so only exemplar_index.cpp may).
#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "texsynth/patches/exemplar_index.hpp"

namespace texsynth {

// An HNSW graph as plain link lists, per internal node id: what the cache file stores.
struct HnswLinks {
  int32_t top_level = 0;
  uint32_t entry = 0;
  std::vector<uint32_t> labels;  // origin id of each node
  std::vector<int32_t> levels;   // top level of each node
  std::vector<size_t> first;     // offset of each node's lists in `links`
  std::vector<uint32_t> links;   // per node, per level 0..level: count, then the linked node ids
};

// The graph of `ix`; std::invalid_argument when it has none or its size differs from ix.count().
HnswLinks hnsw_links(const PatchIndex& ix);
// Rebuilds ix.graph from checked link lists (labels a permutation of ix.count(), levels <= top_level,
// link counts <= M (2M at level 0), links to nodes that have that level); reads ix.reduced.
void restore_hnsw_graph(PatchIndex& ix, const HnswLinks& links, const std::atomic<bool>* cancel);

// Representative pixel offsets of a patch (see exemplar_index.hpp, "Regions").
std::vector<std::array<int32_t, 2>> patch_cells(PatchRegion region, int patch_size, int band_width);

}  // namespace texsynth
