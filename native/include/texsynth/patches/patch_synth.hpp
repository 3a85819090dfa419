// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Patch synthesis in a direction field (Chen, Liu & Dong §4–5; docs/algorithms/vector_field_patches.md):
// exemplar patches pasted onto surface samples through grid patches traced along the field
// (grid_patch.hpp), located with coverage.hpp, matched with the exemplar index (exemplar_index.hpp).
//
// Grids are traced with a margin of 1 point on every side (size w + 2): the 5x5 appearance windows of
// the representative pixels (patch pixels 2, 6, ..., w - 2) reach patch pixels 0..w, so they are on the
// surface too (a margin of 2 traced and located 17 % more points for nothing). Grid point (i, j) shows
// exemplar pixel origin + (i - 1, j - 1), and a patch pastes onto the samples with u, v in [1, w].
//
// Surface -> grid: the colours of the settled samples a patch covers are splatted onto its grid
// points with bilinear weights (the paper's barycentric read needs a colour per mesh vertex; this works
// for texels and vertices alike). A grid point is known when its weight is >= 0.25.
//
// Patch sampling (§5; vector_field_patches.md, "Patch sampling"):
//  - patches in order of growth (Dijkstra by centre distance) over patches that share samples, from a
//    seeded start (patch_order in patch_synth.cpp);
//  - candidates: an exact masked search of the full index over the known cells within W_E of the
//    frontier (unknown and farther cells are masked; a separate band index was measured no better and
//    cost preprocessing), refined to the pixel, then one drawn uniformly among those within
//    tolerance × the best;
//    a patch with no known band cell takes a seeded random origin;
//  - paste: the whole patch is written; samples that were already settled are cross-faded over the
//    boundary zone (weight distance-from-border / W_E), so the seam lies where the band was matched.
// Texture optimisation (§4.3; vector_field_patches.md, "Texture optimisation"): starts from the
// patch-sampling result; each iteration matches every patch against the full index and the copies already
// under it (M-step, in parallel)
// and sets each sample by a discrete vote among its patches' proposals (E-step; by default the proposal of
// the patch with the largest ω = (d² + ε²)^((r − 2) / 2), damped in the boundary zone), with r the robust
// exponent ([10]'s 0.8; the paper's |X − Z|^−0.8 is r = 1.2) and ε² = 1e-6 per dimension, which keeps exact
// copies finite. The paper's least-squares E-step (the weighted RGB mean) stays as an option: it averaged
// sparse structure away (issue 29). It stops early when fewer than 1 % of the patches change their match.
#include <atomic>
#include <cstdint>
#include <vector>

#include "texsynth/patches/coverage.hpp"
#include "texsynth/patches/exemplar_index.hpp"

namespace texsynth {

constexpr int kPatchGridMargin = 1;

enum class PatchMode { kSampling, kOptimisation };

// The discrete vote of the E-step (vector_field_patches.md, "Texture optimisation"; docs/benchmarks.md):
//  - kBestPatch (default): each sample keeps the proposal of its best-matching patch, damped within the
//    boundary zone: the structure of whole patches (small bricks keep their head joints);
//  - kNearestMean: each sample keeps the proposal nearest the weighted RGB mean (the paper's [8]): where the
//    overlapping matches disagree on sparse structure (head joints of an irregular wall) the mean, and so
//    the pick, is the majority's plain brick: the 96² brick sample kept 0.57 of its detail.
// Keeping the most interior patch's proposal (a Voronoi of patch cores) broke the most lines.
enum class PatchVote { kNearestMean, kBestPatch };

struct PatchSynthParams {
  PatchMode mode = PatchMode::kSampling;
  double tolerance = 1.2;          // >= 1: candidates within tolerance × the best band distance
  int candidates = 16;             // ANN shortlist, 1..256
  int iterations = 6;              // optimisation: 1..50
  double robust_exponent = 0.8;    // r in (0, 2]
  uint64_t seed = 0;
  int boundary_width = 4;          // W_E: the zone matched and cross-faded, 1 .. patch_size / 2
  bool exhaustive = true;          // sampling: exact masked search over every origin (false: the HNSW
                                   // shortlist of the masked projection, which misses partial matches)
  // Optimisation: every E-step a discrete vote (false: the weighted RGB mean, the last one a vote; its
  // blur fed the next M-step and levels, issue 29).
  bool discrete = true;
  PatchVote vote = PatchVote::kBestPatch;
  // Optimisation: start from these exemplar coordinates (samples × 2, pixel x covers [x, x + 1); < 0:
  // none) instead of a patch-sampling pass: the previous level of a multi-resolution optimisation.
  const float* initial_source = nullptr;
  const std::atomic<bool>* cancel = nullptr;
  std::atomic<float>* progress = nullptr;
};

struct PatchSynthStats {
  double seconds_sampling = 0, seconds_optimisation = 0, seconds_total = 0;
  int32_t patches = 0;
  int32_t random_patches = 0;        // placed without a known band cell
  int64_t uncovered_samples = 0;     // no patch covers them: left at colour 0, source -1
  std::vector<double> energy;        // optimisation: Σ ω d² per iteration
  std::vector<double> changed;       // optimisation: fraction of patches whose match changed
};

struct PatchSynthResult {
  int32_t channels = 0;
  std::vector<float> colour;    // samples × channels
  std::vector<float> source;    // samples × 2: exemplar pixel coordinate (pixel x covers [x, x+1)), -1 if uncovered
  std::vector<int32_t> origin;  // patches × 2: the exemplar patch each grid patch shows
  PatchSynthStats stats;
};

// `patches` must be traced with size = index.patch_size + 2·kPatchGridMargin; `coverage` located on the
// same samples. The index needs its full-patch index. Throws
// std::invalid_argument for mismatched sizes or parameters out of range; texsynth::Cancelled.
// Deterministic for a seed whatever the thread count.
PatchSynthResult synthesize_patches(const GridPatches& patches, const PatchCoverage& coverage, int32_t num_samples,
                                    const ExemplarIndex& index, const ExemplarSample& sample,
                                    const PatchSynthParams& params);

// The whole surface pass: patch centres (Poisson-disk, spacing = centre_spacing × patch size, in
// local steps), grids traced with the margin, samples located, one more round of centres among the
// samples still uncovered (traced and located alone, then merged), then synthesize_patches().
// centre_spacing: w/2 for sampling is 0.5 ("Centres"); the add-on uses 0.3 for optimisation.
// Multi-resolution optimisation (levels > 1; vector_field_patches.md, "Multi-resolution"): the sample is
// halved (2×2 box) per coarser level and the grid step doubled, so the same patch size in pixels spans
// twice the surface; the coarsest level is patch sampling then optimisation, each finer level starts from
// the exemplar coordinates of the one below, ×2 (coordinates up-sampled, not colours: no blur carried up).
constexpr int kMaxPatchLevels = 3;
struct SurfacePatchParams {
  PatchSynthParams synth;
  double centre_spacing = 0.5;  // (0, 1]
  int levels = 3;               // optimisation: 1..kMaxPatchLevels (sampling: 1); README, Vector-field patches
};
struct SurfacePatchResult {
  PatchSynthResult synth;
  int32_t patches = 0, extra_patches = 0;
  int64_t invalid_grid_points = 0;
  double seconds_centres = 0, seconds_trace = 0, seconds_locate = 0;
  double seconds_coarse = 0;     // the coarser levels of a multi-resolution optimisation, all stages
  int32_t levels = 1;            // levels run (coarse samples too small for a patch end the pyramid early)
  int64_t coverage_entries = 0;  // (sample, patch) pairs
  // Samples no patch pasted onto (stats.uncovered_samples), continued from the nearest pasted sample:
  // its exemplar coordinate plus their offset in its frame.
  int64_t extrapolated_samples = 0;
};
SurfacePatchResult synthesize_patches_on_surface(const PatchField& field, const PatchSamples& samples,
                                                 const ExemplarIndex& index, const ExemplarSample& sample,
                                                 const SurfacePatchParams& params);

// One exemplar a surface patch synthesis analyses: the working sample at level 0, halved per coarser
// optimisation level, each with its fitted patch size.
struct PatchLevelSize {
  int width = 0, height = 0, patch_size = 0;
};
// The levels synthesize_patches_on_surface analyses for a width x height sample whose exemplar uses
// patch_size (already fitted), finest first: one for sampling, up to `levels` for optimisation while the
// halved sample still holds the smallest patch. The synthesis follows this plan; callers use it to
// check settings and estimate memory before any work. Throws std::invalid_argument for bad levels.
std::vector<PatchLevelSize> patch_level_sizes(int width, int height, int patch_size, bool tileable, PatchMode mode,
                                              int levels);

}  // namespace texsynth
