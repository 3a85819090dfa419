// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Surface samples of an image target: the texel centres that a UV map puts on a triangle mesh
// (pixel-level synthesis on the surface, Chen & Dong 2008, adapted to an image through UVs).
//
// Texel (x, y) of a width x height image has its centre at UV ((x + 0.5) / width, (y + 0.5) / height);
// row y = 0 is at v = 0 (Blender's pixel order) and its index is y * width + x.
//
// Coverage is exact: UVs are snapped to 1/65536 texel and the edge functions are evaluated in
// 128-bit integers, with a tie rule that counts a centre on an edge or vertex for exactly one of the
// triangles meeting there (the one that a point moved by an infinitesimal (+e, +e^2) would land in).
// So a texel on an edge shared by two triangles is claimed once, and a texel claimed twice is a
// true UV overlap. Mirrored (negative-area) UV triangles are rasterised like the others.
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "texsynth/common/uninitialized_vector.hpp"

namespace texsynth {

// A triangle mesh as Blender's loop triangles, plus the image. Pointers are borrowed.
struct TexelSampleInput {
  const float* positions = nullptr;       // num_vertices * 3
  int32_t num_vertices = 0;
  const int32_t* triangles = nullptr;     // num_triangles * 3 vertex indices
  int32_t num_triangles = 0;
  const float* corner_uvs = nullptr;      // num_triangles * 3 * 2 (u, v) per triangle corner
  const float* corner_normals = nullptr;  // optional num_triangles * 3 * 3; null: area-weighted vertex normals
  int32_t width = 0, height = 0;          // image size in texels
  int32_t margin = 2;                     // gutter width in texels (Euclidean), 0 .. kMaxMarginTexels
};

struct TexelSamples {
  int32_t width = 0, height = 0, margin = 0;
  // One entry per covered texel, sorted by texel index. Not zero-filled first: the parallel fill is
  // the first touch of these pages (they are most of the memory).
  UninitializedVector<int32_t> texel;      // y * width + x
  UninitializedVector<int32_t> triangle;   // the triangle that claims it (the lowest index where UVs overlap)
  UninitializedVector<float> barycentric;  // 2 per sample: weights (b1, b2) of corners 1 and 2; b0 = 1 - b1 - b2
  UninitializedVector<float> position;     // 3 per sample: interpolated position
  UninitializedVector<float> normal;       // 3 per sample: interpolated corner normal, unit length
  UninitializedVector<int32_t> island;     // UV island of the triangle
  // Texels not covered but within `margin` texels (Euclidean, centre to centre) of a covered one,
  // ascending, and for each the index into the samples above of the nearest covered texel (ties:
  // the lowest texel index). For filling bake margins.
  std::vector<int32_t> gutter_texel;
  std::vector<int32_t> gutter_source;
  // Per triangle: its UV island, -1 for degenerate triangles (which belong to none).
  std::vector<int32_t> triangle_island;
  int32_t num_islands = 0;
  int64_t num_overlapping_texels = 0;    // texel centres strictly covered by two or more triangles
  int32_t num_degenerate_triangles = 0;  // skipped: zero-area (or sliver) UV triangles

  size_t size() const { return texel.size(); }
};

// Hard limits. A full image costs at most kTexelSampleBytesPerTexel bytes per texel (every texel a
// sample plus the per-texel owner table); kMaxTexelSampleBytes allows exactly 8192 x 8192 texels.
constexpr int64_t kTexelSampleBytesPerTexel = 4 + 4 + 8 + 12 + 12 + 4 + 4;  // 48
constexpr int64_t kMaxTexelSampleBytes = kTexelSampleBytesPerTexel * 8192 * 8192;  // 3 GiB
constexpr int32_t kMaxTexelImageSide = 65536;   // keeps the fixed-point edge functions exact
constexpr int32_t kMaxMarginTexels = 256;
// UV coordinates farther than this from the origin cannot be snapped exactly; their triangles
// are counted as degenerate (a million UV tiles away, they cannot map the image anyway).
constexpr double kMaxUvMagnitude = 1048576.0;
// A UV triangle whose height over its longest edge is below this (in texels) is degenerate: float
// rounding of collinear UVs leaves slivers this thin, which would otherwise claim texels of their
// neighbours and be reported as overlaps.
constexpr double kMinUvTriangleHeightTexels = 1.0 / 128.0;

// Upper bound of the memory sample_texels needs for a width x height image, in bytes.
int64_t estimate_texel_sample_bytes(int64_t width, int64_t height);

// Throws std::invalid_argument for width or height < 1 or > kMaxTexelImageSide, an image whose estimate
// exceeds kMaxTexelSampleBytes (the message gives the estimate in MB), margin out of range, vertex
// indices out of range, NaN or infinite positions, UVs or normals (naming the triangle or vertex);
// texsynth::Cancelled when *cancel is raised. Same result whatever the thread count.
TexelSamples sample_texels(const TexelSampleInput& in, const std::atomic<bool>* cancel = nullptr);

}  // namespace texsynth
