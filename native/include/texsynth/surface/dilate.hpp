// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Bake margins: uncovered pixels near the covered ones take the colour of the nearest covered
// pixel, so bilinear and mipmapped reads at UV island edges never see the background.
//
// Nearest copy rather than Blender's iterated neighbour average ("Extend"): every margin pixel is
// an exact copy of one island pixel (no blur, no mixing of two islands' colours where their
// margins meet), the result does not depend on an iteration order, and it is the same nearest
// pixel that sample_texels reports as gutter_source, so synthesis and baking agree.
#include <atomic>
#include <cstdint>
#include <vector>

namespace texsynth {

// Uncovered pixels within `margin` pixels (Euclidean, centre to centre) of a covered pixel,
// ascending, each with its nearest covered pixel (ties: the lowest pixel index). Indices are
// y * width + x.
struct MarginPixels {
  std::vector<int32_t> pixel;
  std::vector<int32_t> source;
};

// covered: width * height bytes, non-zero = covered.
MarginPixels find_margin_pixels(const uint8_t* covered, int32_t width, int32_t height, int32_t margin,
                                const std::atomic<bool>* cancel = nullptr);
// owner: width * height values, >= 0 = covered (e.g. the sample or triangle owning each texel).
MarginPixels find_margin_pixels(const int32_t* owner, int32_t width, int32_t height, int32_t margin,
                                const std::atomic<bool>* cancel = nullptr);

// A copy of `image` (height x width x channels floats, row-major) where every margin pixel holds
// the channels of its nearest covered pixel. Covered pixels are copied bit for bit and pixels
// farther than `margin` are left as they were. Throws std::invalid_argument for sizes < 1,
// channels < 1, margin < 0 or > kMaxMarginTexels, or an image too large to index with int32.
std::vector<float> dilate_margin(const float* image, const uint8_t* covered, int32_t width, int32_t height,
                                 int32_t channels, int32_t margin, const std::atomic<bool>* cancel = nullptr);

}  // namespace texsynth
