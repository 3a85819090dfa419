// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/preprocess/working_image.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "texsynth/common/errors.hpp"

namespace texsynth {
namespace {

// Footprint of each output pixel along one axis: source pixels [first, last] with their coverage.
struct Footprint {
  int first = 0;
  std::vector<float> weights;  // normalised, sum 1
};

std::vector<Footprint> footprints(int in, int out) {
  std::vector<Footprint> result(static_cast<size_t>(out));
  const double ratio = double(in) / double(out);
  for (int o = 0; o < out; ++o) {
    const double lo = o * ratio, hi = std::min(double(in), (o + 1) * ratio);
    Footprint& f = result[size_t(o)];
    f.first = int(std::floor(lo));
    const int last = std::min(in - 1, int(std::ceil(hi)) - 1);
    for (int i = f.first; i <= last; ++i)
      f.weights.push_back(float((std::min(hi, double(i + 1)) - std::max(lo, double(i))) / ratio));
  }
  return result;
}

}  // namespace

Size2 working_dimensions(int width, int height, int working_size) {
  const int longest = std::max(width, height);
  if (working_size <= 0 || longest <= working_size) return {width, height};
  const double scale = double(working_size) / double(longest);
  return {std::max(1, int(std::lround(width * scale))), std::max(1, int(std::lround(height * scale)))};
}

std::vector<float> area_downscale(const float* pixels, int width, int height, int channels, int out_width,
                                  int out_height, const std::atomic<bool>* cancel) {
  const std::vector<Footprint> fx = footprints(width, out_width), fy = footprints(height, out_height);
  std::vector<float> out(size_t(out_width) * out_height * channels);
  tbb::parallel_for(tbb::blocked_range<int>(0, out_height, 1), [&](const tbb::blocked_range<int>& rows) {
    std::vector<float> line(size_t(width) * channels);
    for (int oy = rows.begin(); oy < rows.end(); ++oy) {
      throw_if_cancelled(cancel);
      // Vertical pass into one source-width line, then horizontal: fixed order, so deterministic.
      std::fill(line.begin(), line.end(), 0.0f);
      const Footprint& v = fy[size_t(oy)];
      for (size_t j = 0; j < v.weights.size(); ++j) {
        const float* src = pixels + size_t(v.first + int(j)) * width * channels;
        const float w = v.weights[j];
        for (size_t i = 0; i < line.size(); ++i) line[i] += w * src[i];
      }
      float* dst = out.data() + size_t(oy) * out_width * channels;
      for (int ox = 0; ox < out_width; ++ox) {
        const Footprint& h = fx[size_t(ox)];
        for (int c = 0; c < channels; ++c) {
          float sum = 0.0f;
          for (size_t i = 0; i < h.weights.size(); ++i) sum += h.weights[i] * line[size_t(h.first + int(i)) * channels + c];
          dst[size_t(ox) * channels + c] = sum;
        }
      }
    }
  });
  return out;
}

Image working_image(const Image& image, int working_size, const std::atomic<bool>* cancel) {
  const Size2 size = working_dimensions(image.width, image.height, working_size);
  if (size.width == image.width && size.height == image.height) return image;
  Image out;
  out.width = size.width;
  out.height = size.height;
  out.channels = image.channels;
  out.encoding = image.encoding;
  out.pixels = area_downscale(image.pixels.data(), image.width, image.height, image.channels, size.width, size.height,
                              cancel);
  return out;
}

}  // namespace texsynth
