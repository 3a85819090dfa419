// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Preprocessed samples with planted texton labels (no clustering), for texton-synthesis tests
// and benchmarks: random labels, a random symmetric distance table (zero diagonal, off-diagonal
// in [0.5, 1.5]), buckets in CSR form, and one random colour per label as the sample image.
#include <cstdint>
#include <vector>

#include "texsynth/common/rng.hpp"
#include "texsynth/preprocess/preprocessed.hpp"

namespace fixtures {

inline void fill_buckets(texsynth::Preprocessed& pre) {
  const int K = pre.num_textons;
  pre.bucket_start.assign(size_t(K) + 1, 0);
  for (int32_t t : pre.texton_map) ++pre.bucket_start[t + 1];
  for (int t = 0; t < K; ++t) pre.bucket_start[t + 1] += pre.bucket_start[t];
  pre.bucket_pixels.assign(pre.texton_map.size(), 0);
  std::vector<int32_t> fill(pre.bucket_start.begin(), pre.bucket_start.end() - 1);
  for (size_t p = 0; p < pre.texton_map.size(); ++p) pre.bucket_pixels[fill[pre.texton_map[p]]++] = int32_t(p);
}

inline texsynth::Preprocessed label_sample(int width, int height, int num_textons, bool tileable, uint64_t seed = 5) {
  texsynth::Preprocessed pre;
  pre.width = width, pre.height = height, pre.num_textons = num_textons;
  pre.params.tileable = tileable;
  texsynth::Rng rng(seed);
  pre.texton_map.resize(size_t(width) * height);
  for (auto& t : pre.texton_map) t = int32_t(rng.below(uint32_t(num_textons)));
  pre.texton_distances.assign(size_t(num_textons) * num_textons, 0.f);
  for (int a = 0; a < num_textons; ++a)
    for (int b = a + 1; b < num_textons; ++b)
      pre.texton_distances[size_t(a) * num_textons + b] = pre.texton_distances[size_t(b) * num_textons + a] =
          float(0.5 + rng.uniform());
  fill_buckets(pre);
  return pre;
}

// RGB sample: colour of each pixel = a random colour of its label.
inline std::vector<float> label_colours(const texsynth::Preprocessed& pre, uint64_t seed = 9) {
  texsynth::Rng rng(seed);
  std::vector<float> palette(size_t(pre.num_textons) * 3);
  for (auto& c : palette) c = float(rng.uniform());
  std::vector<float> pixels(pre.texton_map.size() * 3);
  for (size_t p = 0; p < pre.texton_map.size(); ++p)
    for (int c = 0; c < 3; ++c) pixels[3 * p + c] = palette[3 * size_t(pre.texton_map[p]) + c];
  return pixels;
}

}  // namespace fixtures
