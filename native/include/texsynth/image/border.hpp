// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Window reads past an image's border: a table from padded coordinate i (i - radius is the real
// coordinate) to a coordinate inside [0, size), mirrored without repeating the edge pixel, or wrapped
// for tileable samples. Used by the feature windows of preprocessing and of vector-field patches.
#include <algorithm>
#include <cstdint>
#include <vector>

namespace texsynth {

inline std::vector<int32_t> border_table(int32_t size, int radius, bool periodic) {
  std::vector<int32_t> table(size_t(size) + 2 * size_t(radius));
  for (int32_t i = 0; i < int32_t(table.size()); ++i) {
    int32_t v = i - radius;
    if (periodic) {
      v = ((v % size) + size) % size;
    } else {
      if (v < 0) v = -v;
      if (v >= size) v = 2 * (size - 1) - v;
      v = std::clamp(v, 0, size - 1);  // radius >= size: clamped rather than out of range
    }
    table[size_t(i)] = v;
  }
  return table;
}

}  // namespace texsynth
