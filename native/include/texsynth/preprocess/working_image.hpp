// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The bounded analysis copy of a sample (PreprocessParams::working_size): area-averaged down so its
// longest side is working_size. Samples that already fit are analysed as they are (bit for bit).
#include <atomic>
#include <cstdint>
#include <vector>

#include "texsynth/image/image.hpp"

namespace texsynth {

struct Size2 {
  int width = 0, height = 0;
};

// Size of the analysis copy: the sample's own when working_size is 0 or the sample fits, else the
// longest side becomes working_size and the other keeps the aspect (rounded, at least 1).
Size2 working_dimensions(int width, int height, int working_size);

// Area average (box filter over each output pixel's footprint) of interleaved float pixels, rows in
// parallel; every output value depends only on its footprint, so any thread count gives the same bytes.
std::vector<float> area_downscale(const float* pixels, int width, int height, int channels, int out_width,
                                  int out_height, const std::atomic<bool>* cancel = nullptr);

// The analysis copy of `image` (a copy of it when it already fits).
Image working_image(const Image& image, int working_size, const std::atomic<bool>* cancel = nullptr);

}  // namespace texsynth
