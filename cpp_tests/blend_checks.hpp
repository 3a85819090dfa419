// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Checks on the blend sets every synthesizer writes (corner_maps.hpp), shared by the method tests.
#include <gtest/gtest.h>

#include <map>
#include <utility>
#include <vector>

#include "mesh_fixtures.hpp"
#include "texsynth/synth/corner_maps.hpp"

namespace fixtures {

// "The same mixture of the same mappings" on both sides of every interior edge (a, b) between two
// polygons of at most max_corners corners that are blended there: in each polygon, the set whose
// weight is 1 at a's corner has bit-identical coordinates at a and at b (and likewise for b's set).
// Weights and coordinates are interpolated linearly along the edge, so both sides then blend
// identical colours there: no seam, not just a weaker one. Returns the number of (edge, end) checks.
inline int expect_c0_across_edges(const TestMesh& t, const texsynth::CornerMaps& maps, int max_corners) {
  const int S = maps.num_blend_sets;
  const size_t L = size_t(maps.num_corners);
  EXPECT_GT(S, 1);
  auto set_at = [&](int32_t corner) {
    int found = -1;
    for (int s = 0; s < S; ++s)
      if (maps.blend_weights[size_t(corner) * S + s] == 1.f) found = s;
    return found;
  };
  auto uv = [&](int set, int32_t corner) { return &maps.blend_uv[(size_t(set) * L + corner) * 2]; };
  std::map<std::pair<int32_t, int32_t>, std::vector<std::pair<int32_t, int32_t>>> sides;  // edge -> (corner a, corner b)
  for (size_t p = 0; p < t.poly_starts.size(); ++p) {
    const int32_t first = t.poly_starts[p], n = t.poly_sizes[p];
    if (n > max_corners || set_at(first) < 0) continue;  // n-gon, or not blended
    for (int32_t i = 0; i < n; ++i) {
      int32_t ca = first + i, cb = first + (i + 1) % n;
      if (t.corner_verts[ca] > t.corner_verts[cb]) std::swap(ca, cb);
      sides[{t.corner_verts[ca], t.corner_verts[cb]}].push_back({ca, cb});
    }
  }
  int checked = 0;
  for (const auto& [edge, list] : sides) {
    if (list.size() != 2) continue;
    for (int end = 0; end < 2; ++end) {  // the mapping of vertex a, then of vertex b
      int32_t own[2], other[2];
      int set[2];
      for (int side = 0; side < 2; ++side) {
        own[side] = end == 0 ? list[side].first : list[side].second;
        other[side] = end == 0 ? list[side].second : list[side].first;
        set[side] = set_at(own[side]);
        EXPECT_GE(set[side], 0) << "corner " << own[side] << " has no one-hot weight";
        if (set[side] < 0) return checked;
      }
      for (int which = 0; which < 2; ++which)
        for (int k = 0; k < 2; ++k) {
          const int32_t c0 = which == 0 ? own[0] : other[0], c1 = which == 0 ? own[1] : other[1];
          EXPECT_EQ(uv(set[0], c0)[k], uv(set[1], c1)[k])
              << "edge (" << edge.first << ", " << edge.second << "): vertex " << (end == 0 ? edge.first : edge.second)
              << "'s mapping differs between its two polygons";
        }
      ++checked;
    }
  }
  return checked;
}

}  // namespace fixtures
