// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/synth/corner_maps.hpp"

#include <stdexcept>
#include <string>

namespace texsynth {

CornerMaps allocate_corner_maps(int32_t num_corners, int32_t num_blend_sets) {
  CornerMaps maps;
  maps.num_corners = num_corners;
  maps.num_blend_sets = num_blend_sets;
  const size_t L = size_t(num_corners), S = size_t(num_blend_sets);
  maps.base_uv.resize(L * 2);
  maps.blend_uv.resize(S * L * 2);
  maps.blend_weights.resize(L * S);
  return maps;
}

CornerMapsView view_of(CornerMaps& maps) {
  return CornerMapsView{maps.num_corners, maps.num_blend_sets, maps.base_uv.data(), maps.blend_uv.data(),
                        maps.blend_weights.data()};
}

void check_corner_maps_view(const CornerMapsView& out, int32_t num_corners, int32_t num_blend_sets,
                            const char* synthesizer) {
  if (out.num_corners != num_corners || out.num_blend_sets != num_blend_sets ||
      (num_corners > 0 && (!out.base_uv || !out.blend_uv || !out.blend_weights)))
    throw std::invalid_argument(std::string(synthesizer) + ": output buffers are missing or sized for " +
                                std::to_string(out.num_corners) + " corners and " + std::to_string(out.num_blend_sets) +
                                " blend sets, expected " + std::to_string(num_corners) + " and " +
                                std::to_string(num_blend_sets));
}

void pack_set_pairs(const float* blend_uv, int32_t num_blend_sets, int32_t num_corners, float* pairs) {
  const size_t L = size_t(num_corners);
  for (int32_t set = 0; set < num_blend_sets + num_blend_sets % 2; ++set)
    for (size_t c = 0; c < L; ++c) {
      float* to = pairs + (size_t(set / 2) * L + c) * 4 + size_t(set % 2) * 2;
      const bool used = set < num_blend_sets;
      to[0] = used ? blend_uv[(size_t(set) * L + c) * 2] : 0.f;
      to[1] = used ? blend_uv[(size_t(set) * L + c) * 2 + 1] : 0.f;
    }
}

}  // namespace texsynth
