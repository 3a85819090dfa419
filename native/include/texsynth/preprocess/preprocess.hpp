// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Preprocessing pipeline: features -> textons (k-means) -> distance table + bucket array -> jump map,
// with an optional on-disk cache (cache.hpp).
#include <atomic>
#include <optional>
#include <string>

#include "texsynth/image/image.hpp"
#include "texsynth/preprocess/preprocessed.hpp"

namespace texsynth {

// Largest K accepted: the K×K distance table must stay small (8192² floats = 256 MB).
constexpr int kMaxTextons = 8192;
constexpr int kMaxJumpCandidates = 32;
// Larger windows make the PCA eigen-solve (dimension n²·channels) impractically slow.
constexpr int kMaxNeighbourhood = 25;
constexpr int kMaxFeatureDims = 2500;  // = 25² · 4 channels, the largest full dimension
// Feature values held in memory at once (floats): 1 GB.
constexpr int64_t kMaxFeatureValues = int64_t(1) << 28;
// PreprocessParams::working_size range (0 = off): below 64 too little of the sample survives.
constexpr int kMinWorkingSize = 64;
constexpr int kMaxWorkingSize = 4096;

// K actually used: params.num_textons, or round(sqrt(pixels)) when 0 (at least 1).
int resolved_num_textons(const PreprocessParams& params, int64_t pixel_count);

// Throws std::invalid_argument naming the problem (even/small n, image smaller than n, K > pixels, ...).
// width/height: the sample as given; the checks apply to its analysis copy (working_size).
void validate_preprocess(const PreprocessParams& params, int width, int height);

// Where the time went, for benchmarks: wall-clock seconds, and process CPU seconds (all threads; less
// sensitive to other processes competing for the cores).
struct PreprocessStats {
  double working_seconds = 0, working_cpu = 0;  // scaling down to the working size
  double features_seconds = 0, kmeans_seconds = 0, tables_seconds = 0, jump_map_seconds = 0;
  double features_cpu = 0, kmeans_cpu = 0, tables_cpu = 0, jump_map_cpu = 0;
  int kmeans_full_iterations = 0, kmeans_subsample_iterations = 0;
  double kmeans_last_change = 0;
};

// The algorithms preprocessing replaced, for benchmarks to time them against the current ones.
struct PreprocessVariant {
  bool full_lloyd = false;  // Lloyd on all points after the subsample (kmeans.hpp)
};

// Computes everything; throws std::invalid_argument for bad input, Cancelled when *cancel is raised.
Preprocessed preprocess(const Image& image, const PreprocessParams& params,
                        const std::atomic<bool>* cancel = nullptr, PreprocessStats* stats = nullptr,
                        const PreprocessVariant& variant = {});

// Like preprocess(), but loads a valid cache from cache_dir or computes and writes one.
// Sets cache_hit and cache_status ("hit", "miss", "recomputed-corrupt").
Preprocessed preprocess_cached(const Image& image, const PreprocessParams& params, const std::string& cache_dir,
                               const std::atomic<bool>* cancel = nullptr);

// Pseudo-colour rendering of the texton map (like Fig. 2 of Magda & Kriegman): H*W*3 bytes.
std::vector<uint8_t> texton_map_colors(const Preprocessed& result);

}  // namespace texsynth
