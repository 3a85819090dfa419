// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Cells of a uniform 3D grid, packed into one 64-bit key (21 bits per axis), for the hash tables
// that find surface samples near a point (patch centres, sample location, unreached samples).
#include <cmath>
#include <cstdint>

#include "texsynth/mesh/vec_math.hpp"

namespace texsynth {

constexpr int64_t kCellKeyOffset = int64_t(1) << 20;

// Integer cell of p for cells of `size`; false when the cell, or a neighbour up to `margin` cells
// away, would not fit the key (coordinates that far out are refused, not wrapped).
inline bool spatial_cell(V3 p, double size, int64_t c[3], int64_t margin = 2) {
  const double q[3] = {p.x / size, p.y / size, p.z / size};
  for (int k = 0; k < 3; ++k) {
    if (!(std::fabs(q[k]) < double(kCellKeyOffset - margin))) return false;
    c[k] = int64_t(std::floor(q[k]));
  }
  return true;
}

inline uint64_t spatial_cell_key(int64_t x, int64_t y, int64_t z) {
  return (uint64_t(x + kCellKeyOffset) << 42) | (uint64_t(y + kCellKeyOffset) << 21) | uint64_t(z + kCellKeyOffset);
}

}  // namespace texsynth
