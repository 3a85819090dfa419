// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/image/blur.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstddef>

#include "texsynth/common/errors.hpp"

namespace texsynth {

std::vector<float> gaussian_blur(const float* pixels, int32_t width, int32_t height, int32_t channels, double sigma,
                                 bool wrap, const std::atomic<bool>* cancel) {
  const int32_t W = width, H = height, C = channels;
  std::vector<float> out(pixels, pixels + size_t(W) * H * C);
  if (sigma <= 0) return out;
  const int r = std::max(1, int(std::ceil(3 * sigma)));
  std::vector<float> kernel(size_t(2 * r + 1));
  double total = 0;
  for (int i = -r; i <= r; ++i) total += kernel[size_t(i + r)] = float(std::exp(-0.5 * i * i / (sigma * sigma)));
  for (float& k : kernel) k = float(k / total);
  auto index = [wrap](int32_t v, int32_t n) { return wrap ? ((v % n) + n) % n : std::clamp(v, 0, n - 1); };
  std::vector<float> tmp(out.size());
  auto pass = [&](const float* src, float* dst, bool along_x) {
    tbb::parallel_for(tbb::blocked_range<int32_t>(0, H, 16), [&](const tbb::blocked_range<int32_t>& rows) {
      throw_if_cancelled(cancel);
      for (int32_t y = rows.begin(); y < rows.end(); ++y)
        for (int32_t x = 0; x < W; ++x)
          for (int32_t c = 0; c < C; ++c) {
            float acc = 0;
            for (int i = -r; i <= r; ++i) {
              const size_t at = along_x ? size_t(y) * W + index(x + i, W) : size_t(index(y + i, H)) * W + x;
              acc += kernel[size_t(i + r)] * src[at * C + c];
            }
            dst[(size_t(y) * W + x) * C + c] = acc;
          }
    });
  };
  pass(pixels, tmp.data(), true);
  pass(tmp.data(), out.data(), false);
  return out;
}

}  // namespace texsynth
