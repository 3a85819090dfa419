// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/patches/exemplar_index.hpp"

#include "exemplar_graph.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

// hnswlib.h defines non-inline functions (cpuid, xgetbv): this must stay the only file including it.
// hnswlib 0.6's SSE prefetches read one link past the end of a list (a heap over-read of up to 3
// bytes that glibc's chunk padding absorbs); AddressSanitizer builds (TEXSYNTH_SANITIZE) turn its
// hand-written SIMD off so they can run clean.
#if defined(__SANITIZE_ADDRESS__)
#define NO_MANUAL_VECTORIZATION
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define NO_MANUAL_VECTORIZATION
#endif
#endif
#include <hnswlib/hnswlib.h>

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <mutex>
#include <sstream>

#include "texsynth/common/errors.hpp"
#include "texsynth/common/fixed_order_product.hpp"
#include "texsynth/common/hash.hpp"
#include "texsynth/common/rng.hpp"
#include "texsynth/image/border.hpp"
#include "texsynth/image/image.hpp"

// Defaults, measured with bench_patches_exemplar (2-core machine, Release, SSE-only hnswlib
// distances; 32² patches, 30 dims; queries single-threaded; "noisy" = an origin's vector + 10 %
// noise, "blend" = the mean of two origins, what an early synthesized patch looks like):
//
//   sample (origins)      efc/efs   build s  HNSW us  exact us (batched)  recall@1 noisy/blend  d1 ratio blend
//   bricks 96² (4225)      64/64     0.18     20        43 (26)            1.000 / 0.81          1.020
//   moss 160² (16641)      32/64     0.35     38       138 (59)            1.000 / 0.95          1.004
//                          64/64     0.64     45       138 (60)            1.000 / 0.98          1.002
//                         100/64     0.98     52       152 (59)            1.000 / 0.99          1.001
//   bricks 192² (25921)    32/64     0.48     41       213 (93)            0.981 / 0.68          1.036
//                          64/32     1.01     44       315 (124)           0.995 / 0.68          1.046
//                          64/64     0.82     44       216 (95)            0.999 / 0.72          1.042
//                          64/128    0.84     73       217 (93)            0.999 / 0.76          1.027
//                         100/64     1.41     44       215 (92)            0.999 / 0.75          1.028
//   bricks 256² (50625)    64/64     2.00     59       438 (189)           0.999 / 0.71          1.036
//                         100/128    3.02     97       407 (167)           1.000 / 0.79          1.025
//
//  - M = 16 and ef_search = 64 (vector_field_patches.md, "Exemplar analysis"). ef_construction 64, not 100:
//    the same recall on queries near the data, 40 % less build time (the graph is ~90 % of the
//    preprocessing).
//  - Queries between patches (blend) miss the exact first often on bricks (many near-equal
//    mortar patches), but the first HNSW finds is on average 2-4 % farther than the exact one,
//    inside the 1.2 x d_min tolerance patch sampling picks from ("Patch sampling").
//  - The exact search is the baseline and stays useful: below about kExactSearchMaxOrigins origins
//    (the coarse levels) its batched form is about as fast as HNSW and exact.

namespace texsynth {

struct HnswGraph {
  hnswlib::L2Space space;
  hnswlib::HierarchicalNSW<float> hnsw;
  HnswGraph(int dims, size_t count, int m, int ef_construction, uint64_t seed)
      : space(size_t(dims)), hnsw(&space, std::max<size_t>(count, 1), size_t(m), size_t(ef_construction),
                                  size_t(splitmix64(seed ^ 0x686e7377ull) & 0x7fffffffull)) {}
};

namespace {

// L2Space's constructor stores the SIMD distance it picks in a global (with -mavx builds): graphs
// built at the same time (full and band) create their spaces one at a time.
std::shared_ptr<HnswGraph> make_graph(int dims, size_t count, int m, int ef_construction, uint64_t seed) {
  static std::mutex mutex;
  std::lock_guard<std::mutex> lock(mutex);
  return std::make_shared<HnswGraph>(dims, count, m, ef_construction, seed);
}

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

[[noreturn]] void refuse(const std::string& what) { throw std::invalid_argument("exemplar index: " + what); }

// Monotone progress in [p0, p1] of the caller's bar.
class Progress {
 public:
  Progress(std::atomic<float>* out, double p0, double p1) : out_(out), p0_(p0), p1_(p1) {}
  void set(double fraction) const {
    if (!out_) return;
    const float v = float(std::clamp(p0_ + (p1_ - p0_) * fraction, 0.0, 1.0));
    float seen = out_->load(std::memory_order_relaxed);
    while (v > seen && !out_->compare_exchange_weak(seen, v, std::memory_order_relaxed)) {
    }
  }
  Progress sub(double f0, double f1) const { return Progress(out_, p0_ + (p1_ - p0_) * f0, p0_ + (p1_ - p0_) * f1); }

 private:
  std::atomic<float>* out_;
  double p0_, p1_;
};

struct Pca {
  Eigen::VectorXf mean;   // raw
  Eigen::MatrixXf basis;  // out x raw
};

// PCA of `total` raw vectors of which `samples` evenly spaced ones are read through
// gather(id, out). The covariance is summed over a fixed number of chunks, in order, so the result
// does not depend on the thread count. Eigenvectors get a fixed sign (largest component positive).
template <typename Gather>
Pca fit_pca(int raw, int out, int64_t total, int64_t samples, const Gather& gather, const std::atomic<bool>* cancel) {
  samples = std::min(samples, total);
  constexpr int64_t kBlock = 1024;
  const int64_t chunks = std::min<int64_t>(8, (samples + kBlock - 1) / kBlock);
  std::vector<Eigen::MatrixXd> cov(size_t(chunks), Eigen::MatrixXd::Zero(raw, raw));
  std::vector<Eigen::VectorXd> sum(size_t(chunks), Eigen::VectorXd::Zero(raw));
  auto sample_id = [&](int64_t k) { return (2 * k + 1) * total / (2 * samples); };
  tbb::parallel_for(int64_t(0), chunks, [&](int64_t c) {
    const int64_t b0 = c * samples / chunks, b1 = (c + 1) * samples / chunks;
    Eigen::MatrixXf block(raw, kBlock);
    Eigen::MatrixXf product(raw, raw);
    for (int64_t s = b0; s < b1; s += kBlock) {
      throw_if_cancelled(cancel);
      const int64_t n = std::min(kBlock, b1 - s);
      for (int64_t k = 0; k < n; ++k) gather(sample_id(s + k), block.col(k).data());
      const auto cols = block.leftCols(n);
      product_fixed_order(product, cols, cols.transpose());
      cov[size_t(c)] += product.cast<double>();
      sum[size_t(c)] += cols.rowwise().sum().cast<double>();
    }
  });
  Eigen::MatrixXd c_total = Eigen::MatrixXd::Zero(raw, raw);
  Eigen::VectorXd s_total = Eigen::VectorXd::Zero(raw);
  for (int64_t c = 0; c < chunks; ++c) {
    c_total += cov[size_t(c)];
    s_total += sum[size_t(c)];
  }
  const Eigen::VectorXd mean = s_total / double(samples);
  c_total = c_total / double(samples) - mean * mean.transpose();
  throw_if_cancelled(cancel);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> solver(c_total);
  const Eigen::MatrixXd& vectors = solver.eigenvectors();  // ascending eigenvalues
  Pca pca;
  pca.mean = mean.cast<float>();
  pca.basis.resize(out, raw);
  for (int i = 0; i < out; ++i) {
    Eigen::VectorXd v = vectors.col(raw - 1 - i);
    Eigen::Index largest;
    v.cwiseAbs().maxCoeff(&largest);
    if (v[largest] < 0) v = -v;
    pca.basis.row(i) = v.cast<float>().transpose();
  }
  return pca;
}

int64_t origin_count(int32_t w, int32_t h, int p, bool tileable) {
  return tileable ? int64_t(w) * h : int64_t(std::max(0, w - p + 1)) * std::max(0, h - p + 1);
}

}  // namespace

std::vector<std::array<int32_t, 2>> patch_cells(PatchRegion region, int p, int band) {
  std::vector<std::array<int32_t, 2>> cells;
  const int n = p / kPatchCellSize;
  auto in_band = [&](int i) { return kPatchCellSize * i < band || kPatchCellSize * (i + 1) > p - band; };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i)
      if (region == PatchRegion::kFull || in_band(i) || in_band(j))
        cells.push_back({kPatchCellSize * i + kPatchCellOffset, kPatchCellSize * j + kPatchCellOffset});
  return cells;
}

namespace {

// Per-element bytes of hnswlib 0.6-0.8: level-0 links + data + label, level and link-list pointer,
// label map entry, upper levels (1/M of the nodes on average).
int64_t hnsw_bytes(int64_t count, int m, int dims) {
  const int64_t level0 = int64_t(2 * m) * 4 + 4 + int64_t(dims) * 4 + 8;
  const int64_t upper = (int64_t(m) * 4 + 4) / std::max(1, m - 1) + 1;
  return count * (level0 + 4 + 8 + 48 + upper + 2 * 2 /* visited lists */);
}

void check_range(const char* name, int value, int lo, int hi) {
  if (value < lo || value > hi)
    refuse(std::string(name) + " must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " +
           std::to_string(value));
}

void validate_patch_size(int p) {
  if (p % kPatchCellSize != 0 || p < kMinPatchSize || p > kMaxPatchSize)
    refuse("patch size must be a multiple of 4 in [8, 64], got " + std::to_string(p));
}

void validate_hnsw(const HnswParams& h) {
  check_range("HNSW M", h.M, 2, 64);
  check_range("HNSW ef_construction", h.ef_construction, 1, 1000);
  check_range("HNSW ef_search", h.ef_search, 1, 4096);
}

void validate_fit(int32_t w, int32_t h, int p, bool tileable) {
  const int32_t need = tileable ? p : p + 3;
  if (w < need || h < need)
    refuse("a " + std::to_string(w) + " x " + std::to_string(h) + " sample is too small for " + std::to_string(p) +
           "² patches (each side needs >= " + std::to_string(need) + "; fit_patch_size picks a patch size that fits)");
}

void validate_sample(const ExemplarSample& s) {
  if (!s.pixels) refuse("sample pixels are null");
  if (s.channels != 3 && s.channels != 4) refuse("sample must have 3 or 4 channels, got " + std::to_string(s.channels));
  if (s.width < 1 || s.height < 1 || int64_t(s.width) * s.height > kMaxImagePixels)
    refuse("sample size " + std::to_string(s.width) + " x " + std::to_string(s.height) + " is out of range");
  const size_t n = size_t(s.width) * size_t(s.height) * size_t(s.channels);
  for (size_t i = 0; i < n; ++i)
    if (!(std::fabs(s.pixels[i]) <= kMaxPixelMagnitude)) {  // also false for NaN
      const size_t px = i / size_t(s.channels);
      refuse("sample pixel (" + std::to_string(px % size_t(s.width)) + ", " + std::to_string(px / size_t(s.width)) +
             ") is NaN, infinite or beyond 1e9");
    }
}

ExemplarAppearance appearance_impl(const ExemplarSample& s, int dims, bool tileable, const std::atomic<bool>* cancel,
                                   const Progress& progress) {
  const int r = kAppearanceWindow / 2, C = s.channels;
  const int raw = kAppearanceWindow * kAppearanceWindow * C;
  check_range("appearance dims", dims, 1, raw);
  if (!tileable && (s.width <= r || s.height <= r)) refuse("sample is smaller than the 5x5 appearance window");
  ExemplarAppearance a;
  a.width = s.width;
  a.height = s.height;
  a.tileable = tileable;
  a.space.channels = C;
  a.space.dims = dims;
  a.space.weights.resize(kAppearanceWindow * kAppearanceWindow);
  const double sigma = kAppearanceWindow / 4.0;
  for (int dy = 0; dy < kAppearanceWindow; ++dy)
    for (int dx = 0; dx < kAppearanceWindow; ++dx)
      a.space.weights[size_t(dy * kAppearanceWindow + dx)] =
          float(std::exp(-double((dx - r) * (dx - r) + (dy - r) * (dy - r)) / (2 * sigma * sigma)));
  const std::vector<int32_t> xs = border_table(s.width, r, tileable), ys = border_table(s.height, r, tileable);
  const int32_t W = s.width;
  auto gather = [&](int64_t id, float* out) {
    const int32_t x = int32_t(id % W), y = int32_t(id / W);
    int o = 0;
    for (int dy = 0; dy < kAppearanceWindow; ++dy) {
      const float* row = s.pixels + size_t(ys[size_t(y + dy)]) * size_t(W) * size_t(C);
      for (int dx = 0; dx < kAppearanceWindow; ++dx) {
        const float w = a.space.weights[size_t(dy * kAppearanceWindow + dx)];
        const float* px = row + size_t(xs[size_t(x + dx)]) * size_t(C);
        for (int c = 0; c < C; ++c) out[o++] = w * px[c];
      }
    }
  };
  const int64_t pixels = int64_t(W) * s.height;
  const Pca pca = fit_pca(raw, dims, pixels, 65536, gather, cancel);
  progress.set(0.4);
  a.space.mean.assign(pca.mean.data(), pca.mean.data() + raw);
  a.space.basis.resize(size_t(dims) * size_t(raw));
  Eigen::Map<Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(a.space.basis.data(), dims, raw) =
      pca.basis;
  a.values.resize(size_t(pixels) * size_t(dims));
  const Eigen::VectorXf projected_mean = pca.basis * pca.mean;
  std::atomic<int32_t> rows_done{0};
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, s.height, 4), [&](const tbb::blocked_range<int32_t>& rows) {
    Eigen::MatrixXf windows(raw, W);
    for (int32_t y = rows.begin(); y < rows.end(); ++y) {
      throw_if_cancelled(cancel);
      for (int32_t x = 0; x < W; ++x) gather(int64_t(y) * W + x, windows.col(x).data());
      Eigen::Map<Eigen::MatrixXf> out(a.values.data() + size_t(y) * size_t(W) * size_t(dims), dims, W);
      product_fixed_order(out, pca.basis, windows);
      out.colwise() -= projected_mean;
    }
    progress.set(0.4 + 0.6 * double(rows_done += int32_t(rows.size())) / s.height);
  });
  return a;
}

void build_graph(PatchIndex& ix, const std::atomic<bool>* cancel, const Progress& progress);

PatchIndex patch_index_impl(const ExemplarAppearance& a, const PatchIndexSpec& spec, uint64_t seed,
                            const std::atomic<bool>* cancel, const Progress& progress, double* seconds_features,
                            double* seconds_hnsw) {
  validate_patch_size(spec.patch_size);
  validate_hnsw(spec.hnsw);
  check_range("patch dims", spec.dims, 1, kMaxPatchDims);
  if (spec.region != PatchRegion::kFull && spec.region != PatchRegion::kBand) refuse("unknown patch region");
  if (spec.region == PatchRegion::kBand) check_range("band width", spec.band_width, 1, spec.patch_size / 2);
  if (a.space.dims < 1 || a.values.size() != size_t(a.width) * size_t(a.height) * size_t(a.space.dims))
    refuse("appearance is empty or inconsistent");
  validate_fit(a.width, a.height, spec.patch_size, a.tileable);

  auto t0 = Clock::now();
  PatchIndex ix;
  ix.spec = spec;
  if (spec.region == PatchRegion::kFull) ix.spec.band_width = 0;
  ix.sample_width = a.width;
  ix.sample_height = a.height;
  ix.tileable = a.tileable;
  ix.origins_x = a.tileable ? a.width : a.width - spec.patch_size + 1;
  ix.origins_y = a.tileable ? a.height : a.height - spec.patch_size + 1;
  ix.appearance_dims = a.space.dims;
  ix.cells = patch_cells(spec.region, spec.patch_size, spec.band_width);
  ix.raw_dims = int(ix.cells.size()) * a.space.dims;
  ix.dims = std::min(spec.dims, ix.raw_dims);
  const int64_t count = ix.count();
  if (count > int64_t(INT32_MAX) / 2) refuse("too many patch origins");

  auto gather = [&](int64_t id, float* out) { ix.raw_feature(a, int32_t(id), out); };
  // 16k origins pin the covariance of 320-1280 dims well; more only costs time.
  const Pca pca = fit_pca(ix.raw_dims, ix.dims, count, 16384, gather, cancel);
  progress.set(0.05);
  ix.mean.assign(pca.mean.data(), pca.mean.data() + ix.raw_dims);
  ix.basis.resize(size_t(ix.dims) * size_t(ix.raw_dims));
  Eigen::Map<Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(ix.basis.data(), ix.dims,
                                                                                     ix.raw_dims) = pca.basis;
  ix.reduced.resize(size_t(count) * size_t(ix.dims));
  const Eigen::VectorXf projected_mean = pca.basis * pca.mean;
  constexpr int64_t kBlock = 512;
  tbb::parallel_for(tbb::blocked_range<int64_t>(0, (count + kBlock - 1) / kBlock, 1),
                    [&](const tbb::blocked_range<int64_t>& blocks) {
                      Eigen::MatrixXf raw(ix.raw_dims, kBlock);
                      for (int64_t b = blocks.begin(); b < blocks.end(); ++b) {
                        throw_if_cancelled(cancel);
                        const int64_t first = b * kBlock, n = std::min(kBlock, count - first);
                        for (int64_t k = 0; k < n; ++k) gather(first + k, raw.col(k).data());
                        Eigen::Map<Eigen::MatrixXf> out(ix.reduced.data() + size_t(first) * size_t(ix.dims), ix.dims, n);
                        out.noalias() = pca.basis * raw.leftCols(n);
                        out.colwise() -= projected_mean;
                      }
                    });
  progress.set(0.1);
  ix.build_columns(a);
  if (seconds_features) *seconds_features += seconds_since(t0);

  t0 = Clock::now();
  ix.graph_seed = seed;
  build_graph(ix, cancel, progress.sub(0.1, 1.0));
  progress.set(1.0);
  if (seconds_hnsw) *seconds_hnsw += seconds_since(t0);
  return ix;
}

// Single-threaded insertion in a seeded order: the graph (and so every query result) is the same
// whatever the thread count. A shuffled order avoids inserting long runs of near-identical
// neighbouring origins, which raster order would.
void build_graph(PatchIndex& ix, const std::atomic<bool>* cancel, const Progress& progress) {
  const int64_t count = ix.count();
  const uint64_t seed = ix.graph_seed;
  auto graph = make_graph(ix.dims, size_t(count), ix.spec.hnsw.M, ix.spec.hnsw.ef_construction, seed);
  std::vector<int32_t> order(static_cast<size_t>(count));
  for (int32_t i = 0; i < int32_t(count); ++i) order[size_t(i)] = i;
  Rng rng(seed, 0x686e7377ull);  // "hnsw"
  for (int64_t i = count - 1; i > 0; --i) std::swap(order[size_t(i)], order[rng.below(uint32_t(i + 1))]);
  for (int64_t i = 0; i < count; ++i) {
    if ((i & 255) == 0) {
      throw_if_cancelled(cancel);
      progress.set(double(i) / double(count));
    }
    const int32_t id = order[size_t(i)];
    graph->hnsw.addPoint(ix.reduced_at(id), size_t(id));
  }
  graph->hnsw.setEf(size_t(ix.spec.hnsw.ef_search));
  ix.graph = std::move(graph);
}

// Bounded max-heap of the k best (distance, id); ties by lower id.
struct TopK {
  int k;
  std::vector<std::pair<float, int32_t>> heap;
  explicit TopK(int k_) : k(k_) { heap.reserve(size_t(k_) + 1); }
  float worst() const { return int(heap.size()) < k ? INFINITY : heap.front().first; }
  void push(float d, int32_t id) {
    if (int(heap.size()) < k) {
      heap.emplace_back(d, id);
      std::push_heap(heap.begin(), heap.end());
    } else if (std::make_pair(d, id) < heap.front()) {
      std::pop_heap(heap.begin(), heap.end());
      heap.back() = {d, id};
      std::push_heap(heap.begin(), heap.end());
    }
  }
};

std::vector<PatchMatch> to_matches(const PatchIndex& ix, std::vector<std::pair<float, int32_t>>& best) {
  std::sort(best.begin(), best.end());
  std::vector<PatchMatch> out;
  out.reserve(best.size());
  for (const auto& [d, id] : best) {
    const auto o = ix.origin(id);
    out.push_back({o[0], o[1], d});
  }
  return out;
}

// Squared distance summed in index order: the one definition both exact searches rank by.
float exact_distance2(const float* a, const float* b, int dims) {
  float sum = 0.f;
  for (int i = 0; i < dims; ++i) {
    const float d = a[i] - b[i];
    sum += d * d;
  }
  return sum;
}

// Shortlist -> the k best by exact_distance2, nearest first, ties by id.
std::vector<PatchMatch> finish_exact(const PatchIndex& ix, const float* query,
                                     std::vector<std::pair<float, int32_t>>& shortlist, int k) {
  for (auto& [d, id] : shortlist) d = exact_distance2(query, ix.reduced_at(id), ix.dims);
  std::sort(shortlist.begin(), shortlist.end());
  if (int(shortlist.size()) > k) shortlist.resize(size_t(k));
  return to_matches(ix, shortlist);
}

int clamp_k(const PatchIndex& ix, int k) {
  if (k < 1) refuse("k must be >= 1, got " + std::to_string(k));
  if (ix.count() < 1 || ix.dims < 1) refuse("the index is empty");
  return std::min(k, ix.count());
}

}  // namespace

// --- AppearanceSpace / PatchIndex members ---------------------------------------------------------

void AppearanceSpace::project(const float* window, float* out) const {
  const int raw = raw_dims();
  for (int d = 0; d < dims; ++d) {
    const float* row = basis.data() + size_t(d) * size_t(raw);
    double acc = 0;
    for (int i = 0; i < raw; ++i) acc += double(row[i]) * (double(weights[size_t(i / channels)]) * window[i] - mean[size_t(i)]);
    out[d] = float(acc);
  }
}

void PatchIndex::raw_feature(const ExemplarAppearance& a, int32_t id, float* out) const {
  const int32_t ox = id % origins_x, oy = id / origins_x;
  const int d = appearance_dims;
  for (size_t c = 0; c < cells.size(); ++c) {
    int32_t x = ox + cells[c][0], y = oy + cells[c][1];
    if (x >= sample_width) x -= sample_width;  // tileable only: origins < size, offsets < size
    if (y >= sample_height) y -= sample_height;
    std::memcpy(out + c * size_t(d), a.at(x, y), sizeof(float) * size_t(d));
  }
}

void PatchIndex::build_columns(const ExemplarAppearance& a) {
  const int64_t n = count(), D = int64_t(cells.size()) * appearance_dims;
  const int d = appearance_dims;
  columns.resize(size_t(n * D));
  cell_norm.resize(size_t(n) * cells.size());
  // Rows in blocks, transposed through a small row-major buffer: writing one origin's features
  // straight into 80 columns touches 80 pages per origin and was ~10x slower.
  constexpr int64_t kBlock = 256;
  tbb::parallel_for(tbb::blocked_range<int64_t>(0, (n + kBlock - 1) / kBlock, 1), [&](const tbb::blocked_range<int64_t>& r) {
    std::vector<float> rows(size_t(kBlock * D));
    for (int64_t b = r.begin(); b < r.end(); ++b) {
      const int64_t first = b * kBlock, m = std::min(kBlock, n - first);
      for (int64_t k = 0; k < m; ++k) raw_feature(a, int32_t(first + k), &rows[size_t(k * D)]);
      for (int64_t i = 0; i < D; ++i) {
        float* dst = &columns[size_t(i * n + first)];
        for (int64_t k = 0; k < m; ++k) dst[k] = rows[size_t(k * D + i)];
      }
      for (size_t c = 0; c < cells.size(); ++c) {
        float* dst = &cell_norm[c * size_t(n) + size_t(first)];
        for (int64_t k = 0; k < m; ++k) {
          float sum = 0.f;
          for (int e = 0; e < d; ++e) sum += rows[size_t(k * D) + c * d + e] * rows[size_t(k * D) + c * d + e];
          dst[k] = sum;
        }
      }
    }
  });
}

void PatchIndex::project(const float* raw, const uint8_t* valid, float* out) const {
  for (int k = 0; k < dims; ++k) {
    const float* row = basis.data() + size_t(k) * size_t(raw_dims);
    double acc = 0;
    for (int c = 0; c < int(cells.size()); ++c) {
      if (valid && !valid[c]) continue;  // the mean: a zero after centring
      for (int e = 0; e < appearance_dims; ++e) {
        const int i = c * appearance_dims + e;
        acc += double(row[i]) * (double(raw[i]) - mean[size_t(i)]);
      }
    }
    out[k] = float(acc);
  }
}

std::vector<PatchMatch> PatchIndex::search(const float* query, int k) const {
  k = clamp_k(*this, k);
  if (!graph) refuse("the index has no HNSW graph");
  auto result = graph->hnsw.searchKnn(query, size_t(k));
  std::vector<std::pair<float, int32_t>> best;
  best.reserve(result.size());
  for (; !result.empty(); result.pop()) best.emplace_back(result.top().first, int32_t(result.top().second));
  return to_matches(*this, best);
}

std::vector<PatchMatch> PatchIndex::search_exact(const float* query, int k) const {
  k = clamp_k(*this, k);
  // Eigen's vectorised sums shortlist k + 8; the final order uses exact_distance2, as search_batch
  // does, so both exact searches agree on near-ties.
  const Eigen::Map<const Eigen::VectorXf> q(query, dims);
  TopK top(std::min(count(), k + 8));
  constexpr int32_t kBlock = 4096;
  Eigen::VectorXf d2(kBlock);
  for (int32_t first = 0; first < count(); first += kBlock) {
    const int32_t n = std::min(kBlock, count() - first);
    const Eigen::Map<const Eigen::MatrixXf> x(reduced_at(first), dims, n);
    d2.head(n) = (x.colwise() - q).colwise().squaredNorm().transpose();
    for (int32_t i = 0; i < n; ++i)
      if (d2[i] <= top.worst()) top.push(d2[i], first + i);
  }
  return finish_exact(*this, query, top.heap, k);
}

std::vector<PatchMatch> PatchIndex::search_batch(const float* queries, int32_t n_queries, int k, bool exact) const {
  k = clamp_k(*this, k);
  if (n_queries < 0) refuse("query count must be >= 0");
  std::vector<PatchMatch> out(size_t(n_queries) * size_t(k));
  if (!exact) {
    tbb::parallel_for(tbb::blocked_range<int32_t>(0, n_queries, 16), [&](const tbb::blocked_range<int32_t>& r) {
      for (int32_t q = r.begin(); q < r.end(); ++q) {
        const auto m = search(queries + size_t(q) * size_t(dims), k);
        std::copy(m.begin(), m.end(), out.begin() + ptrdiff_t(size_t(q) * size_t(k)));
      }
    });
    return out;
  }
  // |q - x|² = |q|² - 2 q.x + |x|² as one product per block of queries x block of origins, a
  // shortlist of 2k + 8 per query (rounding in the expansion can swap near-ties), then exact
  // distances of the shortlist.
  Eigen::VectorXf norms(count());
  for (int32_t i = 0; i < count(); ++i) norms[i] = Eigen::Map<const Eigen::VectorXf>(reduced_at(i), dims).squaredNorm();
  const int shortlist = std::min(count(), 2 * k + 8);
  constexpr int32_t kQueryBlock = 64, kOriginBlock = 4096;
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, (n_queries + kQueryBlock - 1) / kQueryBlock, 1),
                    [&](const tbb::blocked_range<int32_t>& blocks) {
                      Eigen::MatrixXf dots(kOriginBlock, kQueryBlock);
                      for (int32_t b = blocks.begin(); b < blocks.end(); ++b) {
                        const int32_t q0 = b * kQueryBlock, nq = std::min(kQueryBlock, n_queries - q0);
                        const Eigen::Map<const Eigen::MatrixXf> Q(queries + size_t(q0) * size_t(dims), dims, nq);
                        std::vector<TopK> tops(size_t(nq), TopK{shortlist});
                        for (int32_t first = 0; first < count(); first += kOriginBlock) {
                          const int32_t n = std::min(kOriginBlock, count() - first);
                          const Eigen::Map<const Eigen::MatrixXf> X(reduced_at(first), dims, n);
                          dots.topLeftCorner(n, nq).noalias() = X.transpose() * Q;
                          for (int32_t j = 0; j < nq; ++j) {
                            TopK& top = tops[size_t(j)];
                            for (int32_t i = 0; i < n; ++i) {
                              const float d = norms[first + i] - 2.f * dots(i, j);  // |q|² added later
                              if (d <= top.worst()) top.push(d, first + i);
                            }
                          }
                        }
                        for (int32_t j = 0; j < nq; ++j) {
                          const auto m = finish_exact(*this, queries + size_t(q0 + j) * size_t(dims),
                                                      tops[size_t(j)].heap, k);
                          std::copy(m.begin(), m.end(), out.begin() + ptrdiff_t(size_t(q0 + j) * size_t(k)));
                        }
                      }
                    });
  return out;
}

int64_t PatchIndex::memory_bytes() const {
  int64_t bytes = int64_t(sizeof(float)) * int64_t(mean.size() + basis.size() + reduced.size() + columns.size() +
                                                  cell_norm.size());
  if (graph) bytes += hnsw_bytes(count(), spec.hnsw.M, dims);
  return bytes;
}

// --- free functions -----------------------------------------------------------------------------

int fit_patch_size(int width, int height, int requested, bool tileable) {
  validate_patch_size(requested);
  const int side = std::min(width, height);
  if (side >= (tileable ? requested : requested + 3)) return requested;
  const int p = std::min(requested, (side / 2) / kPatchCellSize * kPatchCellSize);
  if (p < kMinPatchSize)
    refuse("a " + std::to_string(width) + " x " + std::to_string(height) +
           " sample is too small for patches (the smallest, 8², needs sides of at least 16)");
  return p;
}

int64_t estimate_exemplar_bytes(int width, int height, int channels, const ExemplarParams& p) {
  const int64_t pixels = int64_t(std::max(0, width)) * std::max(0, height);
  const int raw_app = kAppearanceWindow * kAppearanceWindow * std::max(0, channels);
  // Sample copy is borrowed; appearance image, PCA scratch (8 double covariances + row windows).
  int64_t bytes = pixels * std::max(1, p.appearance_dims) * 4 + 8 * int64_t(raw_app) * raw_app * 8 +
                  2 * int64_t(raw_app) * std::max(0, width) * 4;
  const int64_t count = origin_count(width, height, p.patch_size, p.tileable);
  for (int r = 0; r < 2; ++r) {
    if (!(r == 0 ? p.full_index : p.band_index)) continue;
    const auto cells = patch_cells(r == 0 ? PatchRegion::kFull : PatchRegion::kBand, std::max(0, p.patch_size),
                                   std::max(1, p.band_width));
    const int64_t raw = int64_t(cells.size()) * std::max(1, p.appearance_dims);
    const int dims = int(std::min<int64_t>(std::max(1, p.patch_dims), raw));
    // reduced vectors + HNSW (own copy of them) + insertion order + PCA scratch.
    bytes += count * dims * 4 + hnsw_bytes(count, p.hnsw.M, dims) + count * 4 + 8 * raw * raw * 8 + 2 * raw * 1024 * 4 +
             count * (raw + int64_t(cells.size())) * 4;  // + the feature columns
  }
  return bytes;
}

uint64_t exemplar_key(const ExemplarSample& s, const ExemplarParams& p) {
  uint64_t h = 0x6578656d706c6172ull;  // "exemplar"
  if (s.pixels && s.width > 0 && s.height > 0 && s.channels > 0)
    h = hash_bytes(s.pixels, size_t(s.width) * size_t(s.height) * size_t(s.channels) * sizeof(float), h);
  for (uint64_t v : {uint64_t(kExemplarFormatVersion), uint64_t(uint32_t(s.width)), uint64_t(uint32_t(s.height)),
                     uint64_t(uint32_t(s.channels)), uint64_t(uint32_t(p.patch_size)), uint64_t(p.tileable), p.seed,
                     uint64_t(uint32_t(p.appearance_dims)), uint64_t(uint32_t(p.patch_dims)),
                     uint64_t(uint32_t(p.band_width)), uint64_t(p.full_index), uint64_t(p.band_index),
                     uint64_t(uint32_t(p.hnsw.M)), uint64_t(uint32_t(p.hnsw.ef_construction)),
                     uint64_t(uint32_t(p.hnsw.ef_search))})
    h = hash_combine(h, v);
  return h;
}

ExemplarAppearance build_appearance(const ExemplarSample& sample, int appearance_dims, bool tileable,
                                    const std::atomic<bool>* cancel) {
  validate_sample(sample);
  return appearance_impl(sample, appearance_dims, tileable, cancel, Progress(nullptr, 0, 1));
}

PatchIndex build_patch_index(const ExemplarAppearance& appearance, const PatchIndexSpec& spec, uint64_t seed,
                             const std::atomic<bool>* cancel, std::atomic<float>* progress) {
  return patch_index_impl(appearance, spec, seed, cancel, Progress(progress, 0, 1), nullptr, nullptr);
}

ExemplarIndex build_exemplar_index(const ExemplarSample& s, const ExemplarParams& p) {
  const auto t0 = Clock::now();
  const Progress progress(p.progress, 0, 1);
  if (p.progress) p.progress->store(0.f, std::memory_order_relaxed);
  validate_sample(s);
  validate_patch_size(p.patch_size);
  validate_fit(s.width, s.height, p.patch_size, p.tileable);
  check_range("appearance dims", p.appearance_dims, 1, kAppearanceWindow * kAppearanceWindow * s.channels);
  check_range("patch dims", p.patch_dims, 1, kMaxPatchDims);
  if (p.band_index) check_range("band width", p.band_width, 1, p.patch_size / 2);
  validate_hnsw(p.hnsw);
  if (!p.full_index && !p.band_index) refuse("neither the full nor the band index was requested");
  if (!(p.max_megabytes > 0)) refuse("max_megabytes must be > 0");
  const int64_t estimate = estimate_exemplar_bytes(s.width, s.height, s.channels, p);
  if (double(estimate) > p.max_megabytes * 1e6) {
    std::ostringstream msg;
    msg << "a " << s.width << " x " << s.height << " sample with " << p.patch_size << "² patches needs about "
        << std::llround(double(estimate) / 1e6) << " MB (limit " << p.max_megabytes
        << " MB); use a smaller sample or fewer indices";
    refuse(msg.str());
  }
  throw_if_cancelled(p.cancel);

  ExemplarIndex out;
  out.key = exemplar_key(s, p);
  out.width = s.width;
  out.height = s.height;
  out.channels = s.channels;
  out.patch_size = p.patch_size;
  out.tileable = p.tileable;
  out.seed = p.seed;
  out.stats.estimated_bytes = estimate;
  auto t = Clock::now();
  const double app_share = 0.1;
  out.appearance = appearance_impl(s, p.appearance_dims, p.tileable, p.cancel, progress.sub(0, app_share));
  out.stats.seconds_appearance = seconds_since(t);
  // The two graphs are built at the same time, each by one thread (so each is the same whatever the
  // thread count): on 2 cores full + band costs about one graph (256²: 3.7 s one after the other,
  // 1.9 s together).
  // Both report into the same stretch of the bar; the slower one sets it.
  double seconds[2][2] = {{0, 0}, {0, 0}};
  auto build = [&](int r) {
    PatchIndexSpec spec;
    spec.region = r == 0 ? PatchRegion::kFull : PatchRegion::kBand;
    spec.patch_size = p.patch_size;
    spec.band_width = p.band_width;
    spec.dims = p.patch_dims;
    spec.hnsw = p.hnsw;
    // Each index its own seed stream, so the band graph does not repeat the full one's levels.
    (r == 0 ? out.full : out.band) = patch_index_impl(out.appearance, spec, hash_combine(p.seed, uint64_t(r)), p.cancel,
                                                      progress.sub(app_share, 1.0), &seconds[r][0], &seconds[r][1]);
  };
  if (p.full_index && p.band_index) {
    tbb::parallel_invoke([&] { build(0); }, [&] { build(1); });
  } else {
    build(p.full_index ? 0 : 1);
  }
  out.stats.seconds_features = seconds[0][0] + seconds[1][0];
  out.stats.seconds_hnsw = seconds[0][1] + seconds[1][1];
  out.stats.index_bytes = int64_t(out.appearance.values.size() + out.appearance.space.basis.size()) * 4 +
                          (out.full ? out.full->memory_bytes() : 0) + (out.band ? out.band->memory_bytes() : 0);
  out.stats.seconds_total = seconds_since(t0);
  progress.set(1.0);
  return out;
}

// --- HNSW graph as link lists (for exemplar_cache.cpp) --------------------------------------------
// The cache stores the graph as its link lists and restores them into a fresh hnswlib index:
// rebuilding from the reduced vectors took as long as the first build (bench_patches_exemplar,
// 256², 32² patches: 1.8 s of a 1.9 s preprocessing), and hnswlib's own loadIndex trusts its input
// (a corrupt link list is read out of bounds). This touches hnswlib's public members (link lists,
// levels, labels), which 0.6 and 0.8 name and lay out alike.

HnswLinks hnsw_links(const PatchIndex& ix) {
  if (!ix.graph) throw std::invalid_argument("serialize_exemplar_index: an index without its HNSW graph");
  const auto& h = ix.graph->hnsw;
  if (h.cur_element_count != size_t(ix.count())) throw std::invalid_argument("serialize_exemplar_index: graph size");
  HnswLinks out;
  out.top_level = int32_t(h.maxlevel_);
  out.entry = uint32_t(h.enterpoint_node_);
  const size_t n = size_t(ix.count());
  out.labels.resize(n);
  out.levels.resize(n);
  out.first.resize(n);
  for (hnswlib::tableint i = 0; i < hnswlib::tableint(n); ++i) {
    out.labels[i] = uint32_t(h.getExternalLabel(i));
    const int level = h.element_levels_[i];
    out.levels[i] = level;
    out.first[i] = out.links.size();
    for (int l = 0; l <= level; ++l) {
      hnswlib::linklistsizeint* list = l == 0 ? h.get_linklist0(i) : h.get_linklist(i, l);
      const unsigned short count = h.getListCount(list);
      out.links.push_back(count);
      const auto* ids = reinterpret_cast<const hnswlib::tableint*>(list + 1);
      for (unsigned short k = 0; k < count; ++k) out.links.push_back(ids[k]);
    }
  }
  return out;
}

void restore_hnsw_graph(PatchIndex& ix, const HnswLinks& links, const std::atomic<bool>* cancel) {
  const uint32_t n = uint32_t(ix.count());
  const uint32_t max_m = uint32_t(ix.spec.hnsw.M), max_m0 = 2 * max_m;
  auto graph = make_graph(ix.dims, size_t(n), ix.spec.hnsw.M, ix.spec.hnsw.ef_construction, ix.graph_seed);
  auto& h = graph->hnsw;
  if (h.maxM0_ != max_m0 || h.maxM_ != max_m || h.data_size_ != size_t(ix.dims) * sizeof(float))
    throw std::runtime_error("exemplar index: unexpected hnswlib layout");
  for (uint32_t i = 0; i < n; ++i) {
    if ((i & 4095) == 0) throw_if_cancelled(cancel);
    const uint32_t label = links.labels[i];
    const int32_t level = links.levels[i];
    std::memset(h.data_level0_memory_ + size_t(i) * h.size_data_per_element_ + h.offsetLevel0_, 0,
                h.size_data_per_element_);
    h.setExternalLabel(i, label);
    std::memcpy(h.getDataByInternalId(i), ix.reduced_at(int32_t(label)), h.data_size_);
    h.element_levels_[i] = level;
    h.linkLists_[i] = nullptr;
    if (level > 0) {
      h.linkLists_[i] = static_cast<char*>(std::malloc(h.size_links_per_element_ * size_t(level) + 1));
      if (!h.linkLists_[i]) {
        h.element_levels_[i] = 0;
        h.cur_element_count = i;
        throw std::bad_alloc();
      }
      std::memset(h.linkLists_[i], 0, h.size_links_per_element_ * size_t(level) + 1);
    }
    h.cur_element_count = i + 1;  // the destructor frees what is counted
    size_t at = links.first[i];
    for (int32_t l = 0; l <= level; ++l) {
      hnswlib::linklistsizeint* list = l == 0 ? h.get_linklist0(i) : h.get_linklist(i, l);
      const uint32_t count = links.links[at++];
      h.setListCount(list, static_cast<unsigned short>(count));
      std::memcpy(list + 1, links.links.data() + at, sizeof(uint32_t) * count);
      at += count;
    }
    h.label_lookup_[label] = i;
  }
  h.enterpoint_node_ = links.entry;
  h.maxlevel_ = links.top_level;
  h.setEf(size_t(ix.spec.hnsw.ef_search));
  ix.graph = std::move(graph);
}

}  // namespace texsynth
