// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/preprocess/jump_map.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#ifdef __SSE2__
#include <emmintrin.h>
#endif

#include "texsynth/common/errors.hpp"
#include "texsynth/common/fixed_order_product.hpp"
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

// First index i in [from, end) with values[i] < threshold, or end: most candidates lie above the
// threshold once k jumps are known, so skip them four at a time.
inline int next_below(const float* values, int from, int end, float threshold) {
  int i = from;
#ifdef __SSE2__
  const __m128 limit = _mm_set1_ps(threshold);
  for (; i + 4 <= end; i += 4) {
    const int mask = _mm_movemask_ps(_mm_cmplt_ps(_mm_loadu_ps(values + i), limit));
    if (mask) return i + __builtin_ctz(unsigned(mask));
  }
#endif
  for (; i < end; ++i)
    if (values[i] < threshold) return i;
  return end;
}

inline int axis_distance(int a, int b, int size, bool periodic) {
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
  if (int64_t(labels.size()) != int64_t(width) * height || bucket_pixels.size() != labels.size() ||
      features.count != int64_t(labels.size()) || bucket_start.size() < 2 ||
      int(bucket_start.size()) - 1 != textons.num_centres || bucket_start.back() != int32_t(labels.size()))
    throw std::invalid_argument("build_jump_map: inconsistent texton data");
  for (size_t t = 0; t + 1 < bucket_start.size(); ++t)
    if (bucket_start[t] < 0 || bucket_start[t] > bucket_start[t + 1])
      throw std::invalid_argument("build_jump_map: bucket offsets not ascending");
  if (textons.list_length < 1 || textons.list_length > textons.num_centres ||
      textons.order.size() != size_t(textons.num_centres) * size_t(textons.list_length))
    throw std::invalid_argument("build_jump_map: bad texton index");
  for (int32_t t : textons.order)
    if (t < 0 || t >= textons.num_centres) throw std::invalid_argument("build_jump_map: bad texton index");
  for (int32_t q : bucket_pixels)
    if (q < 0 || int64_t(q) >= int64_t(labels.size())) throw std::invalid_argument("build_jump_map: bad bucket pixel");
  const int64_t n = int64_t(width) * height;
  const int k = params.k;
  const int dims = features.dims;
  JumpMap map;
  map.k = k;
  map.targets.assign(size_t(n) * k, -1);
  std::vector<float> distances(size_t(n) * k, 0.0f);

  // Candidates are read bucket by bucket: copy features and coordinates into bucket order so each
  // scan streams through memory instead of jumping across the whole sample.
  std::vector<float> bucket_features(size_t(n) * dims);
  std::vector<uint16_t> bucket_x(static_cast<size_t>(n)), bucket_y(static_cast<size_t>(n));
  tbb::parallel_for(tbb::blocked_range<int64_t>(0, n, 4096), [&](const tbb::blocked_range<int64_t>& r) {
    for (int64_t i = r.begin(); i < r.end(); ++i) {
      const int32_t q = bucket_pixels[size_t(i)];
      std::copy(features.row(q), features.row(q) + dims, bucket_features.data() + size_t(i) * dims);
      bucket_x[size_t(i)] = uint16_t(q % width);
      bucket_y[size_t(i)] = uint16_t(q / width);
    }
  });
  const int radius = params.neighbourhood / 2;
  const int num_textons = int(bucket_start.size()) - 1;
  constexpr int kQueryBlock = 64;

  // Queries are grouped by texton: a block of up to 64 pixels of texton t shares one candidate set
  // (t's bucket, then the buckets of t's nearest textons, up to max_candidates; buckets too big for the
  // remaining budget are sampled with a stride so candidates spread over the whole sample). Distances
  // of a block to its candidates are one small GEMM: |c|² + |q|² − 2 c·q.
  tbb::parallel_for(tbb::blocked_range<int>(0, num_textons, 1), [&](const tbb::blocked_range<int>& range) {
    std::vector<int32_t> candidates;  // positions in bucket order
    Eigen::MatrixXf candidate_matrix, products, scaled_queries;
    Eigen::VectorXf candidate_norms;
    for (int t = range.begin(); t < range.end(); ++t) {
      if (cancel && cancel->load(std::memory_order_relaxed)) return;
      const int32_t own_begin = bucket_start[size_t(t)], own_end = bucket_start[size_t(t) + 1];
      for (int32_t block = own_begin; block < own_end; block += kQueryBlock) {
        if (cancel && cancel->load(std::memory_order_relaxed)) return;
        const int block_size = std::min<int32_t>(kQueryBlock, own_end - block);
        candidates.clear();
        Rng rng(params.seed ^ splitmix64(uint64_t(t)), uint64_t(block));
        const int32_t* order = textons.nearest(t);
        for (int j = 0; j < textons.list_length && int(candidates.size()) < params.max_candidates; ++j) {
          const int32_t begin = bucket_start[size_t(order[j])], count = bucket_start[size_t(order[j]) + 1] - begin;
          const int32_t budget = std::min<int32_t>(count, params.max_candidates - int32_t(candidates.size()));
          const double stride = double(count) / double(std::max(budget, 1));
          const double phase = budget < count ? rng.uniform() : 0.0;
          for (int32_t i = 0; i < budget; ++i) candidates.push_back(begin + int32_t((i + phase) * stride));
        }
        const int c_n = int(candidates.size());
        if (c_n == 0) continue;
        candidate_matrix.resize(dims, c_n);
        for (int c = 0; c < c_n; ++c)
          std::copy_n(bucket_features.data() + size_t(candidates[size_t(c)]) * dims, dims, candidate_matrix.col(c).data());
        candidate_norms = candidate_matrix.colwise().squaredNorm().transpose();
        const Eigen::Map<const Eigen::MatrixXf> queries(bucket_features.data() + size_t(block) * dims, dims, block_size);
        // partial(c, q) = |c|² − 2 c·q; adding |q|² gives the squared distance (constant per query). The −2
        // goes into the queries: scaling by a power of two is exact, so the products are bit-identical to
        // scaling them afterwards, without that extra pass over c_n × block_size values.
        scaled_queries.noalias() = queries * -2.0f;
        product_fixed_order(products, candidate_matrix.transpose(), scaled_queries);  // c_n × block_size
        products.colwise() += candidate_norms;
        for (int qi = 0; qi < block_size; ++qi) {
          const size_t query_at = size_t(block + qi);
          const int px = bucket_x[query_at], py = bucket_y[query_at];
          const float query_norm = queries.col(qi).squaredNorm();
          const float* partial = products.col(qi).data();
          TopK best(k);
          float threshold = std::numeric_limits<float>::max();
          for (int c = 0; c < c_n; ++c) {
            c = next_below(partial, c, c_n, threshold);
            if (c == c_n) break;
            const float d = partial[c] + query_norm;
            const size_t at = size_t(candidates[size_t(c)]);
            if (std::max(axis_distance(px, bucket_x[at], width, params.tileable),
                         axis_distance(py, bucket_y[at], height, params.tileable)) <= radius)
              continue;
            best.offer(int32_t(at), d);
            if (best.size == k) threshold = best.worst() - query_norm;
          }
          // Exact distances for the winners (the GEMM form loses precision to cancellation).
          TopK exact(k);
          const float* query = bucket_features.data() + query_at * dims;
          for (int i = 0; i < best.size; ++i)
            exact.offer(bucket_pixels[size_t(best.target[i])],
                        squared_distance(query, bucket_features.data() + size_t(best.target[i]) * dims, dims));
          const int64_t p = bucket_pixels[query_at];
          for (int i = 0; i < exact.size; ++i) {
            map.targets[size_t(p) * k + i] = exact.target[i];
            distances[size_t(p) * k + i] = exact.distance[i];
          }
        }
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
