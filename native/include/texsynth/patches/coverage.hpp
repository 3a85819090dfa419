// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Which grid patches cover which surface samples (vector-field patches, issue 14;
// docs/algorithms/vector_field_patches.md, "Centres" and "Paste").
//
//  - Centres: Poisson-disk over the samples, radius = spacing (in grid steps) × the local step h(x).
//    Candidates are one seeded-random sample per occupied hash cell, accepted in a seeded order when no
//    accepted centre is within the radius (the paper's random vertices leave holes and crowd dense
//    tessellation). choose_patch_centres(..., only) adds centres among the uncovered samples.
//  - Location: a sample lies in cell (i, j) of a patch at (s, t) when inverse-bilinear coordinates in the
//    cell's mean plane are within [-0.01, 1.01], the sample is within half a step of that plane and its
//    normal within 60 degrees of the cell's (no pasting through thin parts). Each sample is located in
//    every patch whose bounding sphere holds it: a first guess from the patch's centre frame, then a walk
//    from cell to cell (at most 12 moves).
#include <atomic>
#include <cstdint>
#include <vector>

#include "texsynth/patches/grid_patch.hpp"

namespace texsynth {

// Borrowed per-sample data (vertices of a dense mesh, or texel centres through a UV map).
struct PatchSamples {
  const float* positions = nullptr;   // count*3
  const float* normals = nullptr;     // count*3, unit (optional: no facing test without)
  const int32_t* triangle = nullptr;  // count: the triangle each sample lies in
  const float* barycentric = nullptr; // count*2: (b1, b2)
  int32_t count = 0;
};

// Patch centres, as surface points, spaced `spacing` grid steps apart (local h). `only` (optional,
// one byte per sample) restricts the candidates to the samples marked 1. Deterministic for a seed.
std::vector<FacePoint> choose_patch_centres(const PatchField& field, const PatchSamples& samples, double spacing,
                                            uint64_t seed, const uint8_t* only = nullptr,
                                            const std::atomic<bool>* cancel = nullptr);

// Samples located in patches, both ways round (CSR).
struct PatchCoverage {
  // Per sample: the patches covering it, ascending, with the sample's grid coordinates (u, v) =
  // (i + s, j + t) in each.
  std::vector<int64_t> sample_start;  // count + 1
  std::vector<int32_t> sample_patch;
  std::vector<float> sample_uv;       // 2 per entry
  // Per patch: the samples it covers, ascending, with the same coordinates.
  std::vector<int64_t> patch_start;   // patches + 1
  std::vector<int32_t> patch_sample;
  std::vector<float> patch_uv;        // 2 per entry
  int64_t uncovered = 0;              // samples in no patch
};

// Throws std::invalid_argument for missing arrays, a patch count mismatch, samples outside the mesh;
// texsynth::Cancelled when *cancel is raised. Same result for any thread count.
// first_patch: only patches from this one on are located (the others cover nothing), to add patches
// to a coverage with merge_coverage without locating the first ones again.
PatchCoverage locate_samples(const PatchField& field, const GridPatches& patches, const PatchSamples& samples,
                             const std::atomic<bool>* cancel = nullptr, int32_t first_patch = 0);

// The union of two coverages of the same samples (entries of each ascending, as locate_samples gives
// them; b may have more patches): the same as one locate_samples over all patches.
PatchCoverage merge_coverage(const PatchCoverage& a, const PatchCoverage& b);

}  // namespace texsynth
