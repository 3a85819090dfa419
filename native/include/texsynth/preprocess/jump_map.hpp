// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Jump map (Zelinka & Garland): for each pixel up to k pixels with similar neighbourhoods,
// excluding pixels within Chebyshev distance n/2 (periodic when tileable), so a jump always
// lands somewhere new.
//
// Search index: the textons themselves. Pixels are processed texton by texton in blocks of 64; a block's
// candidates are its own texton bucket, then the buckets of the nearest textons (texton distance table),
// up to `max_candidates` pixels; a bucket larger than the remaining budget is sampled with a stride (random
// phase per block) so candidates spread over the whole sample. Block-to-candidate distances are one small
// GEMM; the k winners' distances are recomputed exactly. (bench_preprocess compares this with exact
// brute force and with an hnswlib HNSW index.)
//
// Weights: w_i = exp(-d_i / sigma), d_i the squared feature distance and sigma the median over all
// pixels of their best jump's distance (a typical best match weighs e^-1). If sum w_i > 1 the
// weights are scaled to sum to 1, so good jumps share probability 1 and a pixel with only poor
// matches keeps a smaller total. Weights are quantised down to multiples of 1/65535 (exact 16-bit
// cache storage, sums stay <= 1).
#include <atomic>
#include <cstdint>
#include <vector>

#include "texsynth/preprocess/features.hpp"
#include "texsynth/preprocess/kmeans.hpp"
#include "texsynth/preprocess/preprocessed.hpp"

namespace texsynth {

struct JumpSearchParams {
  int k = 4;
  int neighbourhood = 11;
  bool tileable = false;
  int max_candidates = 768;
  uint64_t seed = 0;
};

// labels/bucket_* describe the textons; textons.nearest(t) lists textons by distance from t (t first).
JumpMap build_jump_map(const Features& features, int width, int height, const std::vector<int32_t>& labels,
                       const std::vector<int32_t>& bucket_start, const std::vector<int32_t>& bucket_pixels,
                       const CentreIndex& textons, const JumpSearchParams& params,
                       const std::atomic<bool>* cancel = nullptr);

// Exact reference: the k nearest allowed pixels by brute force (for tests/benchmarks), squared distances.
void brute_force_jumps(const Features& features, int width, int height, int64_t pixel, const JumpSearchParams& params,
                       std::vector<int32_t>& targets, std::vector<float>& distances);

// True when `a` and `b` lie within each other's excluded neighbourhood.
bool within_exclusion(int64_t a, int64_t b, int width, int height, int neighbourhood, bool tileable);

}  // namespace texsynth
