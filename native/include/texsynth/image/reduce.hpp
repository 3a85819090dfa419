// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Halving an interleaved float image by 2x2 box averages (sample pyramids).
#include <cstdint>
#include <vector>

namespace texsynth {

// dst: (width / 2) × (height / 2) pixels of `channels` floats, each the mean of its 2×2 source pixels
// (an odd last row or column is dropped). Rows keep their order.
void halve_image(const float* src, int32_t width, int32_t height, int32_t channels, std::vector<float>& dst);

}  // namespace texsynth
