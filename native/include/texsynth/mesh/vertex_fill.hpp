// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Filling undefined per-vertex vectors (zero or NaN directions) from defined ones.
#include <cstdint>
#include <vector>

namespace texsynth {

// Every vertex not `known` takes the 3-vector of the nearest known vertex along the adjacency
// (CSR: neighbours of v are adjacency[start[v] .. start[v + 1])), breadth first from every known
// vertex in index order, so the result is deterministic. values: num_vertices × 3, filled in place;
// known: set to 1 for every vertex reached. Vertices of components without a known vertex keep theirs.
void fill_from_known_vertices(const int32_t* start, const int32_t* adjacency, int32_t num_vertices,
                              std::vector<uint8_t>& known, float* values);

}  // namespace texsynth
