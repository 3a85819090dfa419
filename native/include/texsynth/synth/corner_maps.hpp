// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Output contract shared by every synthesizer (jump map, texton strings): everything is indexed
// by Blender corners so the add-on writes each array with one foreach_set.
// UVs are Blender UVs into the ORIGINAL sample: u = x / width, v = 1 - y / height
// (texel space has row 0 at the top; Blender's v = 0 is the bottom row).
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
  float* blend_uv = nullptr;       // S*num_corners*2 (set-major)
  float* blend_weights = nullptr;  // num_corners*S
};

}  // namespace texsynth
