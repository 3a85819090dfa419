// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Deterministic, pruned k-means for textons.
//
// 1. k-means++ seeding on a deterministic subsample; Lloyd iterations on that subsample.
// 2. All points assigned once to the subsample's centres (a texton is a mean of its subsample
//    members). With full_lloyd (the former default, kept as the benchmarks' baseline), or when the
//    subsample holds a quarter of the points or more, Lloyd iterations then continue on all points
//    until <= change_fraction of them change cluster.
// Assignment is exact but pruned: starting from a guess c (previous label, or the previous pixel's),
// centres are scanned in increasing distance from c and the scan stops once
// |c - c'| >= |x - c| + |x - best| (triangle inequality: no later centre can be closer).
// Every per-point result depends only on (seed, point index), so results are bit-identical for any
// thread count; centre sums run per cluster over its members in index order.
#include <atomic>
#include <cstdint>
#include <vector>

#include "texsynth/preprocess/features.hpp"

namespace texsynth {

struct KMeansParams {
  int num_clusters = 0;
  uint64_t seed = 0;
  double change_fraction = 0.01;
  int max_iterations = 50;
  int subsample_size = 0;  // 0 = automatic (max(32*K, 20000), capped at the point count)
  bool full_lloyd = false;  // keep iterating on all points after the subsample (slow; baseline)
};

struct KMeansResult {
  int num_clusters = 0;
  int dims = 0;
  std::vector<float> centres;   // num_clusters*dims
  std::vector<int32_t> labels;  // one per point
  int iterations = 0;           // full-data iterations run
  int subsample_iterations = 0; // iterations on the subsample
  double last_change_fraction = 0.0;
};

// Throws std::invalid_argument if num_clusters is not in [1, count]; texsynth::Cancelled if *cancel.
KMeansResult kmeans(const Features& points, const KMeansParams& params,
                    const std::atomic<bool>* cancel = nullptr);

// The centre update of a Lloyd step where the texton and the particle k-means differ; each choice
// changes the centres (and so the textons or classes), so both stay.
struct MeanRule {
  bool reciprocal = true;    // mean = sum * (1 / count) (textons); false: sum / count (particle classes)
  bool reseed_empty = true;  // an empty cluster moves to a seeded random point (textons); false: it keeps its centre
};
// Centres = means of the labelled rows (`count` rows of `dims` floats): double sums per cluster over
// the rows in index order, then `rule`. seed and iteration pick the reseeded rows.
void update_centres(const float* points, int64_t count, int dims, const int32_t* labels, int k, uint64_t seed,
                    int iteration, const MeanRule& rule, std::vector<float>& centres);

// Exact nearest centre for every point (for tests and the baseline): brute force.
std::vector<int32_t> assign_brute_force(const Features& points, const std::vector<float>& centres, int k);
// The same over `count` rows of `dims` floats into labels[count]: squared_distance, ties to the lower
// centre. Also the particle analysis's assignment (particles/analysis_segmentation.cpp).
// texsynth::Cancelled if *cancel.
void assign_brute_force(const float* points, int64_t count, int dims, const std::vector<float>& centres, int k,
                        int32_t* labels, const std::atomic<bool>* cancel = nullptr);

// Sum over points of the squared distance to their cluster's mean (computed from the labels).
double within_cluster_sse(const Features& points, const std::vector<int32_t>& labels, int k);

// K×K table of squared Euclidean distances between centres (symmetric, zero diagonal).
std::vector<float> centre_distance_table(const std::vector<float>& centres, int k, int dims);

// For each centre, the `list_length` nearest centres (itself first) and their (non-squared) distances.
struct CentreIndex {
  int num_centres = 0;
  int list_length = 0;
  std::vector<int32_t> order;    // num_centres*list_length
  std::vector<float> distance;   // num_centres*list_length, ascending per centre
  const int32_t* nearest(int c) const { return order.data() + size_t(c) * size_t(list_length); }
  const float* nearest_distance(int c) const { return distance.data() + size_t(c) * size_t(list_length); }
};
CentreIndex build_centre_index(const std::vector<float>& squared_distance_table, int k, int list_length);

// Bucket array B in CSR form (stable: pixels of each texton in increasing index order).
void build_buckets(const std::vector<int32_t>& labels, int k, std::vector<int32_t>& bucket_start,
                   std::vector<int32_t>& bucket_pixels);

}  // namespace texsynth
