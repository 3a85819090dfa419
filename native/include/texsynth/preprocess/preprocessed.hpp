// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The result of preprocessing a sample once: textons (Magda & Kriegman §3.1) and a jump map
// (Zelinka & Garland). Shared contract between preprocessing (producer) and every synthesizer
// (consumers). Pixel addressing everywhere: image convention, row 0 = top,
// pixel index p = y * width + x, pixel (x, y) covers [x, x+1) × [y, y+1) in texel space.
#include <cstdint>
#include <string>
#include <vector>

namespace texsynth {

struct PreprocessParams {
  int neighbourhood = 11;         // n of the n×n Gaussian-weighted window; odd, >= 3
  int num_textons = 0;            // K; 0 = automatic (≈ sqrt(pixel count))
  int jump_candidates = 4;        // k: max jumps stored per pixel
  int feature_dims = 16;          // PCA dimension of features; 0 = keep full n*n*channels
  bool tileable = false;          // treat the sample as periodic
  uint64_t seed = 0;              // k-means initialisation etc.
  double kmeans_change_fraction = 0.01;  // stop when <= this fraction of pixels change cluster
  int kmeans_max_iterations = 50;
  // Longest side of the analysis copy: a larger sample is area-averaged down to it first, so the
  // neighbourhood covers the same share of the picture whatever its pixel count (jump-map and texton
  // UVs are fractions of the image, so the material still samples the full-resolution file).
  // 0 = analyse at the sample's own resolution. 512: measured best (README "Preprocessing").
  int working_size = 512;
};

// Up to k jumps per pixel, fixed stride k. Unused slots have target -1 and weight 0.
// For each pixel the weights sum to at most 1; a pixel with only poor matches has a smaller sum.
struct JumpMap {
  int k = 0;
  std::vector<int32_t> targets;  // width*height*k pixel indices, or -1
  std::vector<float> weights;    // width*height*k
};

struct Preprocessed {
  int width = 0;   // analysis resolution: every pixel index below is in this grid
  int height = 0;
  int sample_width = 0;   // the sample as given (larger than width/height when it was scaled down)
  int sample_height = 0;
  PreprocessParams params;
  uint64_t sample_hash = 0;  // hash of the sample's pixels as they were given

  int num_textons = 0;                 // K actually used
  int texton_dims = 0;                 // dimension of each texton centre (reduced feature space)
  std::vector<int32_t> texton_map;     // width*height texton labels τ
  std::vector<float> textons;          // num_textons*texton_dims cluster centres
  std::vector<float> texton_distances; // num_textons^2, squared-difference distances, symmetric
  // Bucket array B in CSR form: pixels of texton t are bucket_pixels[bucket_start[t] .. bucket_start[t+1]).
  std::vector<int32_t> bucket_start;   // num_textons+1
  std::vector<int32_t> bucket_pixels;  // width*height pixel indices

  JumpMap jump_map;

  bool cache_hit = false;  // true when this object came from an on-disk cache instead of computing
  // How the cache was used: "uncached" (no cache dir), "hit", "miss", "recomputed-corrupt", "loaded".
  std::string cache_status = "uncached";

  int pixel_count() const { return width * height; }
};

}  // namespace texsynth
