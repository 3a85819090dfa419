// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/image/reduce.hpp"

#include <cstddef>

namespace texsynth {

void halve_image(const float* src, int32_t width, int32_t height, int32_t channels, std::vector<float>& dst) {
  const int32_t w = width / 2, h = height / 2, C = channels;
  dst.resize(size_t(w) * size_t(h) * size_t(C));
  for (int32_t y = 0; y < h; ++y)
    for (int32_t x = 0; x < w; ++x)
      for (int32_t k = 0; k < C; ++k) {
        const auto at = [&](int32_t xx, int32_t yy) { return src[(size_t(yy) * size_t(width) + size_t(xx)) * C + k]; };
        dst[(size_t(y) * w + x) * C + k] =
            0.25f * ((at(2 * x, 2 * y) + at(2 * x + 1, 2 * y)) + (at(2 * x, 2 * y + 1) + at(2 * x + 1, 2 * y + 1)));
      }
}

}  // namespace texsynth
