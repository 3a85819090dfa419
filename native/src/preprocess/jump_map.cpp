// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/preprocess/jump_map.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>

#include "texsynth/common/errors.hpp"
#include "texsynth/common/rng.hpp"

namespace texsynth {
namespace {

constexpr int kMaxTopK = 64;

// The k best (smallest distance, then smallest index) candidates seen so far, sorted.
struct TopK {
  explicit TopK(int capacity) : k(capacity) {}
  int k;
  int size = 0;
  int32_t target[kMaxTopK];
  float distance[kMaxTopK];

  float worst() const { return size < k ? std::numeric_limits<float>::max() : distance[size - 1]; }

  void offer(int32_t t, float d) {
    if (size == k && !(d < distance[size - 1] || (d == distance[size - 1] && t < target[size - 1]))) return;
    int i = size < k ? size++ : size - 1;
    while (i > 0 && (d < distance[i - 1] || (d == distance[i - 1] && t < target[i - 1]))) {
      target[i] = target[i - 1];
      distance[i] = distance[i - 1];
      --i;
    }
    target[i] = t;
    distance[i] = d;
  }
};

// Squared distance that gives up (returns >= limit) once the partial sum exceeds limit.
// PCA orders dimensions by variance, so most rejections happen after the first block.
inline float bounded_distance(const float* a, const float* b, int dims, float limit) {
  float sum = 0.0f;
  int d = 0;
  for (; d + 8 <= dims; d += 8) {
    for (int i = 0; i < 8; ++i) {
      const float diff = a[d + i] - b[d + i];
      sum += diff * diff;
    }
    if (sum >= limit) return sum;
  }
  for (; d < dims; ++d) {
    const float diff = a[d] - b[d];
    sum += diff * diff;
  }
  return sum;
}

int axis_distance(int a, int b, int size, bool periodic) {
  int d = std::abs(a - b);
  return periodic ? std::min(d, size - d) : d;
}

}  // namespace

bool within_exclusion(int64_t a, int64_t b, int width, int height, int neighbourhood, bool tileable) {
  const int radius = neighbourhood / 2;
  const int dx = axis_distance(int(a % width), int(b % width), width, tileable);
  const int dy = axis_distance(int(a / width), int(b / width), height, tileable);
  return std::max(dx, dy) <= radius;
}

JumpMap build_jump_map(const Features& features, int width, int height, const std::vector<int32_t>& labels,
                       const std::vector<int32_t>& bucket_start, const std::vector<int32_t>& bucket_pixels,
                       const CentreIndex& textons, const JumpSearchParams& params, const std::atomic<bool>* cancel) {
  if (params.k < 1 || params.k > kMaxTopK) throw std::invalid_argument("jump candidates out of range");
  const int64_t n = int64_t(width) * height;
  const int k = params.k;
  const int dims = features.dims;
  JumpMap map;
  map.k = k;
  map.targets.assign(size_t(n) * k, -1);
  std::vector<float> distances(size_t(n) * k, 0.0f);

  tbb::parallel_for(tbb::blocked_range<int64_t>(0, n, 1024), [&](const tbb::blocked_range<int64_t>& r) {
    if (cancel && cancel->load(std::memory_order_relaxed)) return;
    for (int64_t p = r.begin(); p < r.end(); ++p) {
      TopK best(k);
      const float* query = features.row(p);
      const int px = int(p % width), py = int(p / width);
      const int own = labels[size_t(p)];
      const int32_t* order = textons.nearest(own);
      int examined = 0;
      for (int j = 0; j < textons.list_length && examined < params.max_candidates; ++j) {
        const int t = order[j];
        const int32_t begin = bucket_start[size_t(t)], end = bucket_start[size_t(t) + 1];
        const int32_t count = end - begin;
        if (count == 0) continue;
        const int32_t budget = std::min<int32_t>(count, params.max_candidates - examined);
        // Enter big buckets at a per-pixel offset so the examined part is not always the same rows.
        const int32_t offset =
            budget < count ? int32_t(Rng(params.seed ^ uint64_t(p), uint64_t(t)).below(uint32_t(count))) : 0;
        for (int32_t i = 0; i < budget; ++i) {
          int32_t slot = offset + i;
          if (slot >= count) slot -= count;
          const int32_t q = bucket_pixels[size_t(begin + slot)];
          const int qx = q % width, qy = q / width;
          if (std::max(axis_distance(px, qx, width, params.tileable), axis_distance(py, qy, height, params.tileable)) <=
              params.neighbourhood / 2)
            continue;
          const float limit = best.worst();
          const float d = bounded_distance(query, features.row(q), dims, limit);
          if (d <= limit) best.offer(q, d);
        }
        examined += budget;
      }
      for (int i = 0; i < best.size; ++i) {
        map.targets[size_t(p) * k + i] = best.target[i];
        distances[size_t(p) * k + i] = best.distance[i];
      }
    }
  });
  if (cancel && cancel->load()) throw Cancelled();

  // sigma = median best-jump distance (deterministic: nth_element on a copy).
  std::vector<float> first;
  first.reserve(size_t(n));
  for (int64_t p = 0; p < n; ++p)
    if (map.targets[size_t(p) * k] >= 0) first.push_back(distances[size_t(p) * k]);
  float sigma = 1.0f;
  if (!first.empty()) {
    std::nth_element(first.begin(), first.begin() + first.size() / 2, first.end());
    sigma = first[first.size() / 2];
  }
  if (!(sigma > 0.0f)) sigma = 1e-6f;  // perfectly repetitive sample: every best match is exact

  map.weights.assign(size_t(n) * k, 0.0f);
  tbb::parallel_for(tbb::blocked_range<int64_t>(0, n, 4096), [&](const tbb::blocked_range<int64_t>& r) {
    for (int64_t p = r.begin(); p < r.end(); ++p) {
      double w[kMaxTopK];
      double total = 0.0;
      for (int i = 0; i < k; ++i) {
        w[i] = map.targets[size_t(p) * k + i] >= 0 ? std::exp(-double(distances[size_t(p) * k + i]) / sigma) : 0.0;
        total += w[i];
      }
      const double scale = total > 1.0 ? 1.0 / total : 1.0;
      for (int i = 0; i < k; ++i)
        map.weights[size_t(p) * k + i] = float(std::floor(w[i] * scale * 65535.0) / 65535.0);
    }
  });
  return map;
}

void brute_force_jumps(const Features& features, int width, int height, int64_t pixel, const JumpSearchParams& params,
                       std::vector<int32_t>& targets, std::vector<float>& distances) {
  TopK best(params.k);
  const int64_t n = int64_t(width) * height;
  for (int64_t q = 0; q < n; ++q) {
    if (within_exclusion(pixel, q, width, height, params.neighbourhood, params.tileable)) continue;
    best.offer(int32_t(q), squared_distance(features.row(pixel), features.row(q), features.dims));
  }
  targets.assign(best.target, best.target + best.size);
  distances.assign(best.distance, best.distance + best.size);
}

}  // namespace texsynth
