// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Output contract shared by every synthesizer (jump map, texton strings): everything is indexed
// by Blender corners so the add-on writes each array with one foreach_set.
// UVs are Blender UVs into the ORIGINAL sample: u = x / width, v = 1 - y / height
// (texel space has row 0 at the top; Blender's v = 0 is the bottom row).
#include <cstddef>
#include <cstdint>
#include <vector>

namespace texsynth {

struct CornerMaps {
  int32_t num_corners = 0;
  int32_t num_blend_sets = 0;          // S (3 for all-triangle meshes, 4 when any quad, see docs)
  std::vector<float> base_uv;          // num_corners*2
  std::vector<float> blend_uv;         // S*num_corners*2 (set-major)
  std::vector<float> blend_weights;    // num_corners*S, one-hot per corner
};

// The same outputs in caller-owned buffers (e.g. numpy arrays allocated by the bindings), so a
// synthesizer writes every value once, straight into its final place. Every element is written.
struct CornerMapsView {
  int32_t num_corners = 0;
  int32_t num_blend_sets = 0;
  float* base_uv = nullptr;        // num_corners*2
  float* blend_uv = nullptr;       // S*num_corners*2 (set-major), or pairs of sets (packed_pairs)
  float* blend_weights = nullptr;  // num_corners*S
  // Sets in pairs, (S+1)/2 × num_corners × 4: (u0, v0, u1, v1) then (u2, v2, u3, v3) per corner, the
  // layout of the add-on's RGBA corner attributes (written without a repacking copy). An odd S
  // leaves the last pair's second half to the writer (written as 0).
  bool packed_pairs = false;

  float* set_uv(int32_t set, size_t corner) const {
    return packed_pairs ? blend_uv + (size_t(set / 2) * size_t(num_corners) + corner) * 4 + size_t(set % 2) * 2
                        : blend_uv + (size_t(set) * size_t(num_corners) + corner) * 2;
  }
};

// Buffers sized for the outputs, and a view that writes into them.
CornerMaps allocate_corner_maps(int32_t num_corners, int32_t num_blend_sets);
CornerMapsView view_of(CornerMaps& maps);

// Throws std::invalid_argument, naming `synthesizer`, unless `out` has every buffer and is sized for
// num_corners corners and num_blend_sets sets.
void check_corner_maps_view(const CornerMapsView& out, int32_t num_corners, int32_t num_blend_sets,
                            const char* synthesizer);

// Set-major blend UVs (S × L × 2) repacked into pairs ((S+1)/2 × L × 4, see packed_pairs; 0 where
// an odd S leaves a slot).
void pack_set_pairs(const float* blend_uv, int32_t num_blend_sets, int32_t num_corners, float* pairs);

}  // namespace texsynth
