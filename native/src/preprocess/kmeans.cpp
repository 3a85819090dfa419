// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/preprocess/kmeans.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

#include "texsynth/common/errors.hpp"
#include "texsynth/common/rng.hpp"

namespace texsynth {
namespace {

constexpr int kChunk = 4096;  // fixed work split: results never depend on the scheduler
constexpr int kMaxListLength = 192;

void check_cancel(const std::atomic<bool>* cancel) {
  if (cancel && cancel->load(std::memory_order_relaxed)) throw Cancelled();
}

struct Nearest {
  int label;
  float distance;       // to the nearest centre
  float second_bound;   // lower bound on the distance to any other centre
};

constexpr int kLanes = 8;

// Centres regrouped for lane-parallel distances: kLanes centres per group, stored dimension-major,
// so one pass over the dimensions gives kLanes distances. Each lane adds its terms in the order
// squared_distance() does, so every distance is bit-identical to it (only faster).
struct CentreGroups {
  int dims = 0, list_groups = 0, all_groups = 0;
  std::vector<float> lists;  // per centre: its index list (nearest centres first), list_groups groups
  std::vector<float> all;    // every centre in label order, all_groups groups

  CentreGroups(const std::vector<float>& centres, int k, int dims_, const CentreIndex& index)
      : dims(dims_), list_groups((index.list_length + kLanes - 1) / kLanes), all_groups((k + kLanes - 1) / kLanes) {
    const size_t group_size = size_t(dims) * kLanes;
    lists.assign(size_t(k) * list_groups * group_size, 0.0f);
    all.assign(size_t(all_groups) * group_size, 0.0f);
    auto put = [&](float* groups, int slot, int c) {
      float* g = groups + size_t(slot / kLanes) * group_size + slot % kLanes;
      for (int i = 0; i < dims; ++i) g[size_t(i) * kLanes] = centres[size_t(c) * dims + i];
    };
    for (int c = 0; c < k; ++c) put(all.data(), c, c);
    tbb::parallel_for(tbb::blocked_range<int>(0, k, 16), [&](const tbb::blocked_range<int>& r) {
      for (int c = r.begin(); c < r.end(); ++c)
        for (int j = 0; j < index.list_length; ++j) put(list(c), j, index.nearest(c)[j]);
    });
  }
  float* list(int c) { return lists.data() + size_t(c) * list_groups * dims * kLanes; }
  const float* list(int c) const { return lists.data() + size_t(c) * list_groups * dims * kLanes; }

  // Squared distances from x to the kLanes centres of one group.
  void distances(const float* x, const float* group, float* out) const {
    float acc[kLanes] = {};
    for (int i = 0; i < dims; ++i) {
      const float xi = x[i];
      const float* g = group + size_t(i) * kLanes;
      for (int l = 0; l < kLanes; ++l) {
        const float d = xi - g[l];
        acc[l] += d * d;
      }
    }
    std::copy(acc, acc + kLanes, out);
  }
};

// Exact nearest centre, pruned by the triangle inequality around a pivot centre: the guess, then (when the
// guess's list runs out before the bound closes) the best centre found so far, then brute force.
Nearest nearest_centre(const float* x, int k, const CentreIndex& index, const CentreGroups& groups, int guess) {
  const size_t group_size = size_t(groups.dims) * kLanes;
  float squared[kLanes];
  int best = -1;
  float best_dist = std::numeric_limits<float>::max(), second_dist = std::numeric_limits<float>::max();
  float best_sq = std::numeric_limits<float>::infinity(), second_sq = std::numeric_limits<float>::infinity();
  auto consider = [&](int c, float sq) {
    if (c == best) return;
    // sqrt is monotonic: sq > second_sq gives d >= second_dist > best_dist, which changes nothing below.
    if (sq > second_sq && second_dist > best_dist) return;
    const float d = std::sqrt(sq);
    if (best < 0 || d < best_dist || (d == best_dist && c < best)) {
      second_dist = best_dist;
      second_sq = best_sq;
      best = c;
      best_dist = d;
      best_sq = sq;
    } else if (d < second_dist) {
      second_dist = d;
      second_sq = sq;
    }
  };
  int pivot = guess;
  for (int round = 0; round < 2; ++round) {
    // Distances to the pivot's list, a group at a time, as the scan reaches them.
    const float* list = groups.list(pivot);
    int computed = -1;
    auto list_distance = [&](int j) {
      if (j / kLanes != computed) {
        computed = j / kLanes;
        groups.distances(x, list + size_t(computed) * group_size, squared);
      }
      return squared[j % kLanes];
    };
    const float pivot_sq = list_distance(0);  // the list starts with the pivot itself
    const float pivot_dist = std::sqrt(pivot_sq);
    consider(pivot, pivot_sq);
    const int32_t* order = index.nearest(pivot);
    const float* between = index.nearest_distance(pivot);
    for (int j = 1; j < index.list_length; ++j) {
      // Any centre c' with |p - c'| >= |x - p| + |x - best| is no closer than best (small slack for rounding);
      // every unscanned centre is at least |p - c'| - |x - p| away.
      if (between[j] > (pivot_dist + best_dist) * 1.0001f + 1e-6f)
        return {best, best_dist, std::min(second_dist, between[j] - pivot_dist) * 0.9999f};
      consider(order[j], list_distance(j));
    }
    if (index.list_length >= k) return {best, best_dist, second_dist * 0.9999f};
    if (best == pivot) break;
    pivot = best;
  }
  // Lists exhausted: finish exactly by brute force.
  second_dist = std::numeric_limits<float>::max();
  second_sq = std::numeric_limits<float>::infinity();
  for (int g = 0; g < groups.all_groups; ++g) {
    groups.distances(x, groups.all.data() + size_t(g) * group_size, squared);
    for (int l = 0; l < kLanes && g * kLanes + l < k; ++l) consider(g * kLanes + l, squared[l]);
  }
  return {best, best_dist, second_dist * 0.9999f};
}

// Per-point bounds (Hamerly): upper >= distance to the own centre, lower <= distance to any other.
// After centres move, upper grows by the own centre's drift and lower shrinks by the largest drift;
// a point with upper <= lower provably keeps its label and costs no distance computation.
struct PointBounds {
  std::vector<float> upper, lower;
};

// Assigns every point; labels[i] < 0 means "no previous label" (guess the previous point's).
// Returns how many labels changed.
int64_t assign_all(const Features& points, const std::vector<float>& centres, int k, const CentreIndex& index,
                   std::vector<int32_t>& labels, PointBounds& bounds, const std::atomic<bool>* cancel) {
  const int64_t n = points.count;
  const int dims = points.dims;
  const CentreGroups groups(centres, k, dims, index);
  return tbb::parallel_reduce(
      tbb::blocked_range<int64_t>(0, n, kChunk), int64_t(0),
      [&](const tbb::blocked_range<int64_t>& r, int64_t changed) {
        check_cancel(cancel);
        int previous = 0;
        for (int64_t i = r.begin(); i < r.end(); ++i) {
          const int old = labels[size_t(i)];
          const float* x = points.row(i);
          if (old >= 0) {
            float& upper = bounds.upper[size_t(i)];
            if (upper <= bounds.lower[size_t(i)]) continue;
            upper = std::sqrt(squared_distance(x, centres.data() + size_t(old) * dims, dims));
            if (upper <= bounds.lower[size_t(i)]) continue;
          }
          const Nearest found = nearest_centre(x, k, index, groups, old >= 0 ? old : previous);
          if (found.label != old) ++changed;
          labels[size_t(i)] = found.label;
          bounds.upper[size_t(i)] = found.distance;
          bounds.lower[size_t(i)] = found.second_bound;
          previous = found.label;
        }
        return changed;
      },
      [](int64_t a, int64_t b) { return a + b; }, tbb::simple_partitioner());
}

// Running per-cluster sums (double) so each Lloyd step only touches the points that changed cluster.
// All updates run sequentially in point order: bit-identical whatever the thread count.
class ClusterSums {
 public:
  ClusterSums(int k, int dims) : k_(k), dims_(dims), sums_(size_t(k) * dims, 0.0), counts_(size_t(k), 0) {}

  void add_all(const float* points, int64_t count, const int32_t* labels) {
    for (int64_t i = 0; i < count; ++i) move(points + size_t(i) * size_t(dims_), -1, labels[i]);
  }
  void apply_changes(const Features& points, const std::vector<int32_t>& before, const std::vector<int32_t>& after) {
    for (int64_t i = 0; i < points.count; ++i)
      if (before[size_t(i)] != after[size_t(i)]) move(points.row(i), before[size_t(i)], after[size_t(i)]);
  }
  // Centres = means (see MeanRule); a reseeded empty cluster takes a pseudo-random point from
  // (seed, iteration, cluster).
  void write_centres(const float* points, int64_t count, uint64_t seed, int iteration, const MeanRule& rule,
                     std::vector<float>& centres) const {
    for (int c = 0; c < k_; ++c) {
      float* centre = centres.data() + size_t(c) * dims_;
      if (counts_[size_t(c)] == 0) {
        if (!rule.reseed_empty) continue;
        Rng rng(seed, splitmix64(uint64_t(iteration) * 0x10001ull + uint64_t(c)));
        const float* p = points + size_t(rng.below(uint32_t(count))) * size_t(dims_);
        std::copy(p, p + dims_, centre);
        continue;
      }
      if (rule.reciprocal) {
        const double inv = 1.0 / double(counts_[size_t(c)]);
        for (int d = 0; d < dims_; ++d) centre[d] = float(sums_[size_t(c) * dims_ + d] * inv);
      } else {
        const double n = double(counts_[size_t(c)]);
        for (int d = 0; d < dims_; ++d) centre[d] = float(sums_[size_t(c) * dims_ + d] / n);
      }
    }
  }

 private:
  void move(const float* x, int from, int to) {
    if (from >= 0) {
      --counts_[size_t(from)];
      for (int d = 0; d < dims_; ++d) sums_[size_t(from) * dims_ + d] -= x[d];
    }
    ++counts_[size_t(to)];
    for (int d = 0; d < dims_; ++d) sums_[size_t(to) * dims_ + d] += x[d];
  }
  int k_, dims_;
  std::vector<double> sums_;
  std::vector<int64_t> counts_;
};


// k-means++ seeding (Arthur & Vassilvitskii) on the given points.
std::vector<float> seed_centres(const Features& points, int k, uint64_t seed, const std::atomic<bool>* cancel) {
  const int dims = points.dims;
  const int64_t n = points.count;
  Rng rng(seed, 0x6B6D2B2Bull);  // "km++"
  std::vector<float> centres(size_t(k) * dims);
  std::vector<float> nearest_sq(static_cast<size_t>(n), std::numeric_limits<float>::max());
  const int64_t groups = (n + kLanes - 1) / kLanes;
  std::vector<float> point_groups(size_t(groups) * dims * kLanes, 0.0f);
  for (int64_t p = 0; p < n; ++p)
    for (int i = 0; i < dims; ++i)
      point_groups[size_t(p / kLanes) * dims * kLanes + size_t(i) * kLanes + size_t(p % kLanes)] = points.row(p)[i];
  int64_t chosen = int64_t(rng.below(uint32_t(n)));
  for (int c = 0; c < k; ++c) {
    if ((c & 63) == 0) check_cancel(cancel);
    const float* centre = points.row(chosen);
    std::copy(centre, centre + dims, centres.data() + size_t(c) * dims);
    if (c + 1 == k) break;
    // kLanes points at a time (bit-identical to squared_distance(point, centre) per lane).
    tbb::parallel_for(tbb::blocked_range<int64_t>(0, groups, kChunk / kLanes), [&](const tbb::blocked_range<int64_t>& r) {
      for (int64_t g = r.begin(); g < r.end(); ++g) {
        const float* group = point_groups.data() + size_t(g) * dims * kLanes;
        float acc[kLanes] = {};
        for (int i = 0; i < dims; ++i) {
          const float ci = centre[i];
          for (int l = 0; l < kLanes; ++l) {
            const float d = group[size_t(i) * kLanes + l] - ci;
            acc[l] += d * d;
          }
        }
        for (int l = 0; l < kLanes && g * kLanes + l < n; ++l)
          nearest_sq[size_t(g * kLanes + l)] = std::min(nearest_sq[size_t(g * kLanes + l)], acc[l]);
      }
    });
    double total = 0.0;
    for (float d : nearest_sq) total += d;
    if (!(total > 0.0)) {  // every point coincides with a centre: any choice is as good
      chosen = int64_t(rng.below(uint32_t(n)));
      continue;
    }
    const double target = rng.uniform() * total;
    double running = 0.0;
    chosen = n - 1;
    for (int64_t i = 0; i < n; ++i) {
      running += nearest_sq[size_t(i)];
      if (running > target) {
        chosen = i;
        break;
      }
    }
  }
  return centres;
}

// Lloyd iterations; the final step is always an assignment, so labels are each point's nearest centre.
int lloyd(const Features& points, int k, uint64_t seed, double change_fraction, int max_iterations,
          std::vector<float>& centres, std::vector<int32_t>& labels, double& last_change,
          const std::atomic<bool>* cancel) {
  PointBounds bounds;
  bounds.upper.assign(size_t(points.count), 0.0f);
  bounds.lower.assign(size_t(points.count), 0.0f);
  std::vector<float> previous_centres;
  std::vector<float> drift(static_cast<size_t>(k));
  ClusterSums sums(k, points.dims);
  std::vector<int32_t> previous_labels;
  int iteration = 0;
  for (;; ++iteration) {
    check_cancel(cancel);
    const CentreIndex index =
        build_centre_index(centre_distance_table(centres, k, points.dims), k, std::min(k, kMaxListLength));
    const bool first = labels[0] < 0;
    previous_labels = labels;
    const int64_t changed = assign_all(points, centres, k, index, labels, bounds, cancel);
    last_change = double(changed) / double(points.count);
    if ((!first && last_change <= change_fraction) || iteration >= max_iterations) break;
    previous_centres = centres;
    if (first) {
      sums.add_all(points.values.data(), points.count, labels.data());
    } else {
      sums.apply_changes(points, previous_labels, labels);
    }
    sums.write_centres(points.values.data(), points.count, seed, iteration, MeanRule{}, centres);
    // Other centres moved at most the largest drift, or the second largest for the points of the centre
    // that moved most (Hamerly's refinement: fewer points lose their bound).
    float max_drift = 0.0f, second_drift = 0.0f;
    int max_drift_centre = -1;
    for (int c = 0; c < k; ++c) {
      drift[size_t(c)] = std::sqrt(squared_distance(centres.data() + size_t(c) * points.dims,
                                                    previous_centres.data() + size_t(c) * points.dims, points.dims));
      if (drift[size_t(c)] > max_drift) {
        second_drift = max_drift;
        max_drift = drift[size_t(c)];
        max_drift_centre = c;
      } else {
        second_drift = std::max(second_drift, drift[size_t(c)]);
      }
    }
    tbb::parallel_for(tbb::blocked_range<int64_t>(0, points.count, kChunk), [&](const tbb::blocked_range<int64_t>& r) {
      for (int64_t i = r.begin(); i < r.end(); ++i) {
        const int32_t own = labels[size_t(i)];
        const float others = own == max_drift_centre ? second_drift : max_drift;
        bounds.upper[size_t(i)] += drift[size_t(own)] * 1.0001f + 1e-6f;
        bounds.lower[size_t(i)] -= others * 1.0001f + 1e-6f;
      }
    });
  }
  return iteration;
}

}  // namespace

std::vector<float> centre_distance_table(const std::vector<float>& centres, int k, int dims) {
  std::vector<float> table(size_t(k) * size_t(k), 0.0f);
  tbb::parallel_for(tbb::blocked_range<int>(0, k, 8), [&](const tbb::blocked_range<int>& r) {
    for (int i = r.begin(); i < r.end(); ++i)
      for (int j = i + 1; j < k; ++j) {
        const float d = squared_distance(centres.data() + size_t(i) * dims, centres.data() + size_t(j) * dims, dims);
        table[size_t(i) * k + j] = d;
        table[size_t(j) * k + i] = d;
      }
  });
  return table;
}

CentreIndex build_centre_index(const std::vector<float>& squared_distance_table, int k, int list_length) {
  CentreIndex index;
  index.num_centres = k;
  index.list_length = std::clamp(list_length, 1, k);
  const int len = index.list_length;
  index.order.resize(size_t(k) * len);
  index.distance.resize(size_t(k) * len);
  // Sort keys (squared distance bits, index): squared distances are >= 0, so their IEEE bits order like the
  // values, and one integer compare gives the (distance, index) order without an indirect comparator.
  tbb::parallel_for(tbb::blocked_range<int>(0, k, 8), [&](const tbb::blocked_range<int>& r) {
    std::vector<uint64_t> keys;
    keys.reserve(size_t(k));
    for (int c = r.begin(); c < r.end(); ++c) {
      const float* row = squared_distance_table.data() + size_t(c) * k;
      keys.clear();
      for (int j = 0; j < k; ++j) {
        if (j == c) continue;  // the centre itself goes first
        uint32_t bits;
        std::memcpy(&bits, row + j, sizeof bits);
        keys.push_back(uint64_t(bits) << 32 | uint32_t(j));
      }
      const auto end = keys.begin() + (len - 1);
      if (len < k) std::nth_element(keys.begin(), end, keys.end());
      std::sort(keys.begin(), end);
      int32_t* order = index.order.data() + size_t(c) * len;
      float* distance = index.distance.data() + size_t(c) * len;
      order[0] = c;
      distance[0] = std::sqrt(row[c]);
      for (int j = 1; j < len; ++j) {
        order[j] = int32_t(uint32_t(keys[size_t(j - 1)]));
        distance[j] = std::sqrt(row[order[j]]);
      }
    }
  });
  return index;
}

void build_buckets(const std::vector<int32_t>& labels, int k, std::vector<int32_t>& bucket_start,
                   std::vector<int32_t>& bucket_pixels) {
  bucket_start.assign(size_t(k) + 1, 0);
  for (int32_t t : labels) {
    if (t < 0 || t >= k) throw std::invalid_argument("texton label " + std::to_string(t) + " out of range");
    ++bucket_start[size_t(t) + 1];
  }
  for (int t = 0; t < k; ++t) bucket_start[size_t(t) + 1] += bucket_start[size_t(t)];
  bucket_pixels.resize(labels.size());
  std::vector<int32_t> cursor(bucket_start.begin(), bucket_start.end() - 1);
  for (size_t p = 0; p < labels.size(); ++p) bucket_pixels[size_t(cursor[size_t(labels[p])]++)] = int32_t(p);
}

KMeansResult kmeans(const Features& points, const KMeansParams& params, const std::atomic<bool>* cancel) {
  const int k = params.num_clusters;
  const int64_t n = points.count;
  if (k < 1 || k > n)
    throw std::invalid_argument("number of textons K=" + std::to_string(k) + " must be between 1 and the pixel count " +
                                std::to_string(n));
  const int dims = points.dims;

  // Phase 1: seed and converge on a deterministic subsample (sorted, so neighbours stay neighbours).
  int64_t sub_n = params.subsample_size > 0 ? params.subsample_size : std::max<int64_t>(int64_t(32) * k, 20000);
  sub_n = std::clamp<int64_t>(sub_n, k, n);
  Features sub;
  if (sub_n == n) {
    sub = points;
  } else {
    std::vector<int32_t> ids(static_cast<size_t>(n));
    std::iota(ids.begin(), ids.end(), 0);
    Rng rng(params.seed, 0x73756273ull);  // "subs"
    for (int64_t i = 0; i < sub_n; ++i) std::swap(ids[size_t(i)], ids[size_t(i + rng.below(uint32_t(n - i)))]);
    ids.resize(size_t(sub_n));
    std::sort(ids.begin(), ids.end());
    sub.count = int(sub_n);
    sub.dims = dims;
    sub.values.resize(size_t(sub_n) * dims);
    for (int64_t i = 0; i < sub_n; ++i)
      std::copy(points.row(ids[size_t(i)]), points.row(ids[size_t(i)]) + dims, sub.values.data() + size_t(i) * dims);
  }
  KMeansResult result;
  result.num_clusters = k;
  result.dims = dims;
  result.centres = seed_centres(sub, k, params.seed, cancel);
  double change = 1.0;
  if (sub_n < n) {
    std::vector<int32_t> sub_labels(size_t(sub_n), -1);
    result.subsample_iterations = lloyd(sub, k, params.seed, params.change_fraction, params.max_iterations,
                                        result.centres, sub_labels, change, cancel);
    // Means of the converged subsample clusters seed the full-data phase.
    update_centres(sub.values.data(), sub.count, dims, sub_labels.data(), k, params.seed, 1 << 20, MeanRule{},
                   result.centres);
  }
  sub = Features();

  // Phase 2: all points (one pruned assignment pass unless full_lloyd, or when the subsample is everything).
  result.labels.assign(size_t(n), -1);
  // Small samples (the subsample is a quarter or more of them) still converge on all points: it is cheap
  // there, and keeps their textons as they were.
  const bool converge_all = params.full_lloyd || sub_n * 4 >= n;
  const int full_iterations = converge_all ? params.max_iterations : 0;
  const double subsample_change = change;
  result.iterations = lloyd(points, k, params.seed ^ 0x5A5A5A5Aull, params.change_fraction, full_iterations,
                            result.centres, result.labels, change, cancel);
  // After the single pass, convergence is the subsample's (every label "changed" from none).
  result.last_change_fraction = full_iterations > 0 ? change : subsample_change;
  return result;
}

void update_centres(const float* points, int64_t count, int dims, const int32_t* labels, int k, uint64_t seed,
                    int iteration, const MeanRule& rule, std::vector<float>& centres) {
  ClusterSums sums(k, dims);
  sums.add_all(points, count, labels);
  sums.write_centres(points, count, seed, iteration, rule, centres);
}

void assign_brute_force(const float* points, int64_t count, int dims, const std::vector<float>& centres, int k,
                        int32_t* labels, const std::atomic<bool>* cancel) {
  tbb::parallel_for(tbb::blocked_range<int64_t>(0, count, kChunk), [&](const tbb::blocked_range<int64_t>& r) {
    check_cancel(cancel);
    for (int64_t i = r.begin(); i < r.end(); ++i) {
      const float* x = points + size_t(i) * size_t(dims);
      int best = 0;
      // +inf, as the particle analysis's own loop had: every finite distance, FLT_MAX too, beats it.
      float best_sq = std::numeric_limits<float>::infinity();
      for (int c = 0; c < k; ++c) {
        const float d = squared_distance(x, centres.data() + size_t(c) * size_t(dims), dims);
        if (d < best_sq) {
          best_sq = d;
          best = c;
        }
      }
      labels[i] = best;
    }
  });
}

std::vector<int32_t> assign_brute_force(const Features& points, const std::vector<float>& centres, int k) {
  std::vector<int32_t> labels(size_t(points.count));
  assign_brute_force(points.values.data(), points.count, points.dims, centres, k, labels.data());
  return labels;
}

double within_cluster_sse(const Features& points, const std::vector<int32_t>& labels, int k) {
  const int dims = points.dims;
  std::vector<double> sums(size_t(k) * dims, 0.0);
  std::vector<int64_t> counts(static_cast<size_t>(k), 0);
  for (int64_t i = 0; i < points.count; ++i) {
    const int t = labels[size_t(i)];
    ++counts[size_t(t)];
    for (int d = 0; d < dims; ++d) sums[size_t(t) * dims + d] += points.row(i)[d];
  }
  for (int t = 0; t < k; ++t)
    for (int d = 0; d < dims; ++d) if (counts[size_t(t)]) sums[size_t(t) * dims + d] /= double(counts[size_t(t)]);
  double sse = 0.0;
  for (int64_t i = 0; i < points.count; ++i) {
    const double* mean = sums.data() + size_t(labels[size_t(i)]) * dims;
    for (int d = 0; d < dims; ++d) {
      const double diff = points.row(i)[d] - mean[d];
      sse += diff * diff;
    }
  }
  return sse;
}

}  // namespace texsynth
