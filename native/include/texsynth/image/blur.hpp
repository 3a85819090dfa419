// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Separable Gaussian blur of an interleaved float image (particle segmentation, round synthesis's
// coarsest level).
#include <atomic>
#include <cstdint>
#include <vector>

namespace texsynth {

// width × height pixels of `channels` floats blurred by a Gaussian of `sigma` pixels (radius ceil(3 sigma),
// weights normalised); borders clamp, or wrap. Along x, then along y, each output a fixed-order sum: the same
// bytes at any thread count. sigma <= 0 returns a copy. Throws texsynth::Cancelled when *cancel is raised.
std::vector<float> gaussian_blur(const float* pixels, int32_t width, int32_t height, int32_t channels, double sigma,
                                 bool wrap, const std::atomic<bool>* cancel = nullptr);

}  // namespace texsynth
