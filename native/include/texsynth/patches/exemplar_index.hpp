// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Exemplar analysis for vector-field patches (Chen, Liu & Dong, §4.1;
// docs/algorithms/vector_field_patches.md, "Exemplar analysis"): per-pixel appearance vectors, per-patch
// features over "representative pixels", PCA, and an approximate nearest-neighbour index (hnswlib HNSW)
// next to an exact search as the baseline.
//
// Conventions.
//  - Sample: height x width x channels floats (3 or 4), row y = 0 at the bottom (as round_synth.hpp),
//    compared in the space the values are stored in (no colour conversion: the synthesizer projects
//    its surface colours with the same AppearanceSpace). Alpha, when present, is a fourth channel.
//  - Appearance (§4.1.1): the 5x5 window around a pixel, weighted by one centred Gaussian
//    (sigma = 1.25), PCA to appearance_dims (default 5). Borders mirror (without repeating the edge
//    pixel) unless tileable, where the sample wraps. No feature-distance channel (needs a mask).
//  - Patches: a patch has origin (x, y) = its lowest-left pixel and covers [x, x + w_B) x [y, y + w_B).
//    Origins: every position where the window fits, or every pixel when tileable (windows wrap).
//    Origin id = y * origins_x + x.
//  - Representative pixels (§4.1.2): one per 4x4 cell, cell (i, j) at origin + (4i + 2, 4j + 2); a
//    32² patch has 8x8 cells -> 64 x 5 = 320 raw dims, PCA to patch_dims (default 30). Each
//    appearance vector sees a 5x5 window, so a cell's value depends on the pixels 2 around it.
//  - Regions: kFull uses every cell; kBand only the cells that touch the border band of width W_E
//    (4i < W_E or 4i + 4 > w_B - W_E, same in y): the boundary-zone feature of patch sampling (§5).
//    Both are built by build_patch_index; only the list of cells differs.
//  - Raw patch vector: the appearance vectors of the index's cells, in PatchIndex::cells order
//    (y-major), appearance_dims floats each.
//
// Results are identical for a seed whatever the thread count: PCA covariances are summed over
// fixed chunks in a fixed order, and the HNSW graph is built by single-threaded insertion in a
// seeded order (hnswlib's parallel insertion races on links and gives a different graph per run).
#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace texsynth {

constexpr int kAppearanceWindow = 5;
constexpr int kPatchCellSize = 4;    // representative pixel stride
constexpr int kPatchCellOffset = 2;  // representative pixel within its cell
constexpr int kMinPatchSize = 8;
// 64² patches already have 1280 raw dims (a 1280² covariance); the paper's largest is 40².
constexpr int kMaxPatchSize = 64;
constexpr int kMaxPatchDims = 256;
constexpr double kExemplarDefaultMaxMegabytes = 1500.0;
// Up to this many origins the batched exact search costs about what HNSW does (96², 4225 origins:
// 26 us vs 20 us per query): callers may prefer it there (exemplar_index.cpp, "Defaults").
constexpr int32_t kExactSearchMaxOrigins = 4096;
constexpr uint32_t kExemplarFormatVersion = 1;

// Borrowed sample pixels (see conventions).
struct ExemplarSample {
  const float* pixels = nullptr;  // height*width*channels, row 0 at the bottom
  int32_t width = 0, height = 0, channels = 0;
};

enum class PatchRegion : int32_t { kFull = 0, kBand = 1 };

// HNSW settings. Defaults from bench_patches_exemplar (see exemplar_index.cpp, "Defaults").
struct HnswParams {
  int M = 16;                // links per node (2..64)
  int ef_construction = 64;  // candidate list while inserting (>= 1, <= 1000)
  int ef_search = 64;        // candidate list while querying (>= 1, <= 4096); k above it widens it
};

struct ExemplarParams {
  int patch_size = 32;       // w_B: multiple of 4 in [8, 64]; see fit_patch_size
  bool tileable = false;     // the sample wraps: appearance windows and patches wrap around
  uint64_t seed = 0;
  int appearance_dims = 5;   // 1 .. 25 * channels
  int patch_dims = 30;       // 1 .. kMaxPatchDims; capped at the raw dimension (then exact)
  int band_width = 4;        // W_E for the band index: 1 .. patch_size / 2
  bool full_index = true;    // build the full-patch index
  bool band_index = false;   // build the boundary-band index
  HnswParams hnsw;
  double max_megabytes = kExemplarDefaultMaxMegabytes;  // refuse above this estimate (MB = 1e6 B)
  const std::atomic<bool>* cancel = nullptr;
  std::atomic<float>* progress = nullptr;  // 0..1 while the call runs (optional)
};

// Per-pixel appearance: raw window (25 * channels, Gaussian-weighted) -> PCA.
struct AppearanceSpace {
  int channels = 0;
  int dims = 0;
  std::vector<float> weights;  // 25, row-major (dy outer)
  std::vector<float> mean;     // raw_dims(), of the weighted windows
  std::vector<float> basis;    // dims x raw_dims(), row-major, rows by decreasing variance

  int raw_dims() const { return kAppearanceWindow * kAppearanceWindow * channels; }
  // Appearance vector of one 5x5 window of UNweighted colours: window[(dy * 5 + dx) * channels + c]
  // is the colour at (x + dx - 2, y + dy - 2), y growing upwards like the sample rows.
  void project(const float* window, float* out) const;
};

struct ExemplarAppearance {
  int32_t width = 0, height = 0;
  bool tileable = false;
  AppearanceSpace space;
  std::vector<float> values;  // width*height*space.dims, pixel-major, row 0 at the bottom

  const float* at(int32_t x, int32_t y) const { return values.data() + (size_t(y) * size_t(width) + size_t(x)) * size_t(space.dims); }
};

struct PatchMatch {
  int32_t x = 0, y = 0;    // patch origin
  float distance2 = 0.f;   // squared Euclidean distance in the reduced space
};

struct PatchIndexSpec {
  PatchRegion region = PatchRegion::kFull;
  int patch_size = 32;
  int band_width = 4;  // kBand only
  int dims = 30;       // requested; the index keeps min(dims, raw dims)
  HnswParams hnsw;
};

struct HnswGraph;  // hnswlib lives in exemplar_index.cpp only (its header defines non-inline functions)

struct PatchIndex {
  PatchIndexSpec spec;
  int32_t sample_width = 0, sample_height = 0;
  bool tileable = false;
  int32_t origins_x = 0, origins_y = 0;     // origin grid; count() = origins_x * origins_y
  int appearance_dims = 0;
  std::vector<std::array<int32_t, 2>> cells;  // representative pixel offsets from the origin
  int raw_dims = 0, dims = 0;
  std::vector<float> mean;     // raw_dims
  std::vector<float> basis;    // dims x raw_dims, row-major
  std::vector<float> reduced;  // count() x dims, origin-major
  uint64_t graph_seed = 0;     // HNSW level generator and insertion order
  std::shared_ptr<const HnswGraph> graph;
  // Every origin's raw feature by columns (feature i of origin id at columns[i·count() + id]) and each
  // cell's squared norm (cell_norm[c·count() + id]): an exact masked search then reads only the known
  // cells' columns (patch_synth.cpp). Built with the index and on load, never saved.
  std::vector<float> columns, cell_norm;

  int32_t count() const { return origins_x * origins_y; }
  std::array<int32_t, 2> origin(int32_t id) const { return {id % origins_x, id / origins_x}; }
  const float* reduced_at(int32_t id) const { return reduced.data() + size_t(id) * size_t(dims); }

  // Raw vector -> reduced (dims floats). `valid` (optional, one byte per cell, 0 = unknown) marks
  // cells whose appearance is unknown (e.g. not yet synthesized): their dims are set to the PCA
  // mean before projecting, i.e. they contribute nothing, and the reduced vector is the projection
  // of the known cells alone. Distances to such a query are then only a guide: rerank the
  // candidates by an exact distance over the known cells (raw_feature + the same mask).
  void project(const float* raw, const uint8_t* valid, float* out) const;
  // The raw vector of origin id, read from the appearance it was built from.
  void raw_feature(const ExemplarAppearance& appearance, int32_t id, float* out) const;
  void build_columns(const ExemplarAppearance& appearance);  // fills columns and cell_norm

  // k nearest origins by HNSW (approximate), nearest first; k is capped at count(). Thread-safe.
  std::vector<PatchMatch> search(const float* query, int k) const;
  // Exhaustive search over the reduced vectors (Eigen, blocks of 4096), nearest first, ties by
  // origin id. Thread-safe.
  std::vector<PatchMatch> search_exact(const float* query, int k) const;
  // `count` queries (count x dims floats) -> count x min(k, count()) matches, in parallel.
  // exact = true uses blocked Eigen products (|q|² - 2 q.x + |x|²) to shortlist, then exact distances.
  std::vector<PatchMatch> search_batch(const float* queries, int32_t count, int k, bool exact) const;

  int64_t memory_bytes() const;  // reduced vectors, PCA and the HNSW graph
};

struct ExemplarStats {
  double seconds_appearance = 0;
  double seconds_features = 0;  // patch PCA + projection, summed over the indices
  double seconds_hnsw = 0;      // graph construction (on load: restoration), summed over the indices
                                // (full and band are built at the same time: the wall time is less)
  double seconds_total = 0;
  int64_t estimated_bytes = 0;  // peak estimate the max_megabytes check used
  int64_t index_bytes = 0;      // what the result holds
};

struct ExemplarIndex {
  uint64_t key = 0;  // exemplar_key(sample, params)
  int32_t width = 0, height = 0, channels = 0;
  int patch_size = 0;
  bool tileable = false;
  uint64_t seed = 0;
  ExemplarAppearance appearance;
  std::optional<PatchIndex> full, band;
  ExemplarStats stats;
};

// Patch size for a width x height sample: `requested` if it fits (each side >= requested + 3, or
// >= requested when tileable), else the largest multiple of 4 <= min(requested, smaller side / 2)
// (vector_field_patches.md, "Exemplar analysis": small exemplars get smaller patches). Throws
// std::invalid_argument when requested is not a multiple of 4 in [8, 64], or when even 8 does not
// fit (sides below 16).
int fit_patch_size(int width, int height, int requested, bool tileable = false);

// Peak memory estimate of build_exemplar_index (bytes), without building.
int64_t estimate_exemplar_bytes(int width, int height, int channels, const ExemplarParams& params);

// Content key for caches: hash_bytes over the pixels, the size, the channel count, the format
// version and every parameter that changes the result (not cancel, progress or max_megabytes).
uint64_t exemplar_key(const ExemplarSample& sample, const ExemplarParams& params);

// Throws std::invalid_argument (naming the problem) for: null pixels, channels not 3 or 4, a
// patch size not a multiple of 4 in [8, 64], a sample smaller than patch_size + 3 on a side
// (patch_size when tileable; see fit_patch_size), NaN/inf or |value| > 1e9 pixels, dims, band width
// or HNSW settings out of range, no index requested, or an estimate above max_megabytes (with the
// estimate in MB); texsynth::Cancelled when *cancel is raised.
ExemplarIndex build_exemplar_index(const ExemplarSample& sample, const ExemplarParams& params);

// The two stages separately, for callers that need several patch sizes of one appearance (the
// multi-level stages): appearance_dims and tileable as in ExemplarParams.
ExemplarAppearance build_appearance(const ExemplarSample& sample, int appearance_dims, bool tileable,
                                    const std::atomic<bool>* cancel = nullptr);
PatchIndex build_patch_index(const ExemplarAppearance& appearance, const PatchIndexSpec& spec, uint64_t seed,
                             const std::atomic<bool>* cancel = nullptr, std::atomic<float>* progress = nullptr);

// Disk cache (save, load): exemplar_cache.hpp.

}  // namespace texsynth
