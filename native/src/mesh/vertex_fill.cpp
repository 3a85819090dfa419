// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/mesh/vertex_fill.hpp"

#include <algorithm>

namespace texsynth {

void fill_from_known_vertices(const int32_t* start, const int32_t* adjacency, int32_t num_vertices,
                              std::vector<uint8_t>& known, float* values) {
  std::vector<int32_t> queue;
  queue.reserve(size_t(num_vertices));
  for (int32_t v = 0; v < num_vertices; ++v)
    if (known[v]) queue.push_back(v);
  for (size_t head = 0; head < queue.size(); ++head) {
    const int32_t v = queue[head];
    for (int32_t k = start[v]; k < start[v + 1]; ++k) {
      const int32_t u = adjacency[k];
      if (known[u]) continue;
      known[u] = 1;
      std::copy_n(values + 3 * size_t(v), 3, values + 3 * size_t(u));
      queue.push_back(u);
    }
  }
}

}  // namespace texsynth
