// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Per-pixel neighbourhood features (Magda & Kriegman §3.1): the n×n window around each pixel in
// L*a*b* (+ alpha), multiplied by one centred Gaussian (sigma = n/4), optionally reduced by PCA.
// Borders: mirrored (reflect without repeating the edge pixel), so border pixels see a full,
// unbiased window; with `tileable` the sample is periodic.
#include <atomic>
#include <cstdint>
#include <vector>

#include "texsynth/image/image.hpp"

namespace texsynth {

struct Features {
  int count = 0;              // pixels
  int dims = 0;               // values per pixel
  std::vector<float> values;  // count*dims, pixel-major

  const float* row(int64_t p) const { return values.data() + p * dims; }
};

// Full (unreduced) dimension n*n*feature_channel_count(image).
int full_feature_dims(const Image& image, int neighbourhood);

// feature_dims <= 0 or >= full dimension keeps the full, mean-centred features; otherwise PCA
// (covariance of a deterministic subsample, Eigen) projects onto the leading `feature_dims` axes,
// ordered by decreasing variance. The caller validates the image and neighbourhood.
// Throws texsynth::Cancelled when *cancel is raised (checked per image row).
Features compute_features(const Image& image, int neighbourhood, int feature_dims, bool tileable,
                          uint64_t seed, const std::atomic<bool>* cancel = nullptr);

// Squared Euclidean distance between two feature rows.
inline float squared_distance(const float* a, const float* b, int dims) {
  float sum = 0.0f;
  for (int i = 0; i < dims; ++i) {
    const float d = a[i] - b[i];
    sum += d * d;
  }
  return sum;
}

}  // namespace texsynth
