// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Pixel-based surface texture synthesis with round neighbourhoods and the adaptive metric
// (Chen & Dong 2008, §3–6), decisions in docs/algorithms/round_neighbourhoods.md, adapted to an
// image target through UVs ("Image target") as well as the paper's per-vertex colours.
//
// Two calls, so that a new direction field costs only the synthesis:
//  - build_round_context(): everything that depends on geometry, UVs, target size, scale, levels
//    and ring counts but NOT on the direction field or the sample: the surface points of every
//    level, their parents, the direction-invariant round rings (round_rings.hpp) and the
//    coarsest level's ordering neighbours. This is the expensive part (the ring walks).
//  - synthesize_round(context, sample, directions): sample pyramid, then the levels coarsest first.
//
// Conventions.
//  - Sample: height x width x channels floats (3 or 4), synthesized in the space the values are
//    stored in (e.g. sRGB-encoded). Row index y grows along the texture's "up": the direction field
//    points along +y of the sample, and +x of the sample is up × normal, so seen from outside (normal
//    towards the viewer) the texture is not mirrored. This is Blender's pixel order (row 0 at the
//    bottom, v = 0), the same order as the output image: with a planar UV map and the field along +v,
//    the output image is a rearrangement of the sample, not a mirror image of it.
//  - Source coordinates are continuous, in pixels of the finest (cropped) sample, pixel (x, y)
//    covering [x, x+1) × [y, y+1) (its centre at (x + 0.5, y + 0.5)); they are multiples of 1/4.
//  - Pyramid: the sample is cropped to a multiple of 2^(levels-1) on both sides (columns and rows
//    at the high end are dropped) and box-filtered 2x2 per level. Level 0 is the finest.
//  - Scale: one sample pixel at level l spans r_l = 2^l / (texels_per_unit × multiplier) world
//    units; ring m of level l has radius m·r_l.
//  - Image target: the points of level l are the texel centres of the same UV map at
//    (width >> l) x (height >> l) (texel_samples.hpp), texel (x, y) at UV ((x + .5) / w, (y + .5) / h).
//  - Vertex target: the points are the vertices used by a triangle, the same at every level; r
//    doubles per coarser level (paper-faithful).
//
// Results are bit-identical for a seed whatever the thread count: the coarsest level runs
// sequentially; finer levels run in four fixed passes that read only earlier passes and the
// prediction from the level below.
//
// Decisions where the paper is silent, or where we measured (bench_round, tests):
//  - Template: ring m has the 8m - 4 grid crossings (round_template), at angles counter-clockwise
//    from sample +x; on the surface, angle a of the template is the field direction turned by
//    a - 90° counter-clockwise about the outward normal, read by linear interpolation between the
//    two ring bins around it (ring_sample).
//  - Ring-point colour: bilinear over the level's texels of the triangle's own island (a 2-texel
//    gutter maps to the nearest covered texel), or barycentric over the vertices; renormalised over
//    coloured texels / corners; total weight (bins x texels) < 0.5 = uncoloured.
//  - Candidates: prediction, coherence (every coloured ring bin's dominant point t proposes
//    s_t + its surface offset to us in our frame / r), on the vertex target also the mesh neighbours,
//    hierarchical window, random; kept at first occurrence. Candidates outside the region where the
//    K rings fit are dropped, not clamped (clamping copied the region's edge row into bars).
//  - Source coordinates snap to pixel centres unless the points are >= 1.5 per sample pixel
//    (RoundLevel::density): bilinear reads at arbitrary phases blurred every colour, most visibly on
//    the vertex target where 2·s of a coarse centre is a fine pixel corner.
//  - Random candidates: random_candidates per sample pixel of surface at the coarsest level (per
//    point divided by density²), and 2 for a point with no other candidate.
//  - Metric: literal nested sums with the mean + 2σ clamp (round_neighbourhoods.md, "Metric"); the
//    adaptive cuts start at size 2 (min_top_size) because ring 1 has only 4 points (see RoundSynthParams).
//  - Finer levels: predictions (2·s_parent + the point's offset from its parent, read at that level)
//    give every ring point a colour; passes by 2x2 texel parity (vertex index & 3 on the vertex
//    target) in the order (0,0), (1,1), (1,0), (0,1).
//  - Coarsest order: coverage = synthesized points among the 48 nearest within 2r (a max-heap with
//    lazy deletion, ties by lowest index); a point with none starts from a seeded random permutation.
//  - Fields: vector fields only (no line/cross symmetry); zero vectors take the nearest defined
//    vertex's along mesh edges; a point whose interpolated direction is undefined uses its main
//    corner's, then world +Z, then +Y (counted in stats.undefined_directions).
#include <atomic>
#include <cstdint>
#include <vector>

#include "texsynth/neighbourhood/round_rings.hpp"

namespace texsynth {

constexpr int kRoundMaxLevels = 6;
constexpr int kRoundMaxRandomCandidates = 64;
constexpr int kRoundMaxDistRange = 8;
// A whole synthesis (context + one synthesize call) is refused above this estimate by default.
constexpr double kRoundDefaultMaxMegabytes = 1500.0;
constexpr double kRoundSubpixelRatio = 1.5;

enum class RoundTarget { kImage, kVertices };

// Blender loop triangles. Pointers are borrowed for the duration of build_round_context only.
struct RoundMeshInput {
  const float* positions = nullptr;   // num_vertices*3, finite
  int32_t num_vertices = 0;
  const int32_t* triangles = nullptr;  // num_triangles*3 vertex indices
  int32_t num_triangles = 0;
  const float* corner_uvs = nullptr;   // num_triangles*3*2; required for the image target
};

struct RoundContextParams {
  RoundTarget target = RoundTarget::kImage;
  int32_t width = 0, height = 0;  // image target: output size in texels
  int32_t margin = 2;             // image target: bake margin (texels) filled in the output image
  double texels_per_unit = 0;     // sample pixels per world unit (> 0)
  const float* scale_multiplier = nullptr;  // optional num_vertices floats, finite and > 0
  int levels = 3;                 // 1..kRoundMaxLevels
  int coarse_rings = 4;           // K at the coarsest level, 1..kMaxRings
  int fine_rings = 2;             // K at the finer levels, 1..kMaxRings
  double facing_limit_degrees = 75.0;
  double max_megabytes = kRoundDefaultMaxMegabytes;  // refuse when the estimated peak is above (MB = 1e6 B)
  // Image target: texels covered by two triangles (folded or overlapping UVs) are accepted up to this
  // fraction of the covered texels (the lowest triangle keeps the texel; the other face shows its
  // colour there), refused above. Smart UV Project at Blender's default 66° folds a few texels
  // (78 of 109k on Suzanne, subdivision 2, 512²); overlapping islands cover far more. In [0, 1].
  double max_overlap_fraction = 0.01;
  const std::atomic<bool>* cancel = nullptr;
  std::atomic<float>* progress = nullptr;  // 0..1 while the call runs (optional)
};

// One level's surface points and their direction-invariant data. Read-only after the build.
struct RoundLevel {
  int level = 0;
  int rings = 0;                   // K
  int32_t width = 0, height = 0;   // image target: this level's texel grid
  int32_t num_points = 0;
  std::vector<int32_t> point_id;   // image: texel index y*width + x; vertices: the vertex
  std::vector<int32_t> triangle;   // containing triangle
  std::vector<float> barycentric;  // 2 per point (b1, b2)
  std::vector<float> position;     // 3 per point
  std::vector<float> radius;       // r_l per point (world units)
  std::vector<int32_t> island;     // image: UV island (of the finest level's island table)
  // Image: per texel, the covering point (>= 0), or -2 - p for a texel of the 2-texel gutter whose
  // nearest covered texel is point p (bilinear reads at island edges), or -1.
  std::vector<int32_t> texel_point;
  std::vector<int32_t> parent;     // point of level + 1 (-1: none, or the coarsest level)
  // r / point spacing on the surface (0: unknown): points per sample pixel along a line. Where it
  // is at least kRoundSubpixelRatio, source coordinates keep quarter pixels (a smooth magnification);
  // elsewhere they are pixel centres, so colours are exact sample pixels, never blurred by the
  // bilinear read. Random candidates are spread per sample pixel, not per point (see synthesis).
  std::vector<float> density;
  bool subpixel(int32_t i) const { return density[size_t(i)] >= kRoundSubpixelRatio; }
  RoundRings rings_data;
  // Coarsest level only: for each point q, the points p whose ordering neighbourhood (within 2·r_p,
  // the 48 nearest) contains q (CSR): synthesizing q raises their coverage.
  std::vector<int32_t> cover_start, cover_list;
};

struct RoundContextStats {
  double seconds_points = 0;  // texel sampling / vertex points, parents
  double seconds_rings = 0;   // build_round_rings, all levels
  double seconds_order = 0;   // coarsest-level ordering neighbours
  double seconds_total = 0;
  int64_t estimated_bytes = 0;  // context + a synthesis with a 3-channel 256^2 sample
  std::vector<double> invalid_ring_fraction;  // per level
  int64_t overlapping_texels = 0;  // finest level: texels covered twice (accepted, see max_overlap_fraction)
};

struct RoundSynthesisContext {
  RoundTarget target = RoundTarget::kImage;
  int32_t width = 0, height = 0, margin = 0;
  int32_t num_vertices = 0, num_triangles = 0;
  double texels_per_unit = 0;
  double facing_limit_degrees = 75.0;
  double max_megabytes = kRoundDefaultMaxMegabytes;
  std::vector<int32_t> triangles;        // copy of the mesh's triangles
  std::vector<float> corner_uvs;         // image target: copy of the corner UVs
  std::vector<int32_t> triangle_island;  // image target: -1 for degenerate UV triangles
  std::vector<int32_t> vertex_point;     // vertex -> point (vertex target; -1: unused vertex)
  std::vector<int32_t> vertex_adjacency_start, vertex_adjacency;  // mesh edges (CSR): fields, candidates
  std::vector<RoundLevel> levels;        // [0] = finest
  RoundContextStats stats;
  int64_t context_bytes = 0;             // estimate of what this object holds
};

// Throws std::invalid_argument (naming the problem) for: counts, indices or pointers out of range,
// NaN/inf positions or UVs, texels_per_unit or a multiplier not finite and > 0, levels / rings /
// facing limit out of range, a zero-size target or one too small for the levels, overlapping UVs
// above max_overlap_fraction (with the texel count), no covered texel (or no used vertex), and an estimated peak memory above
// max_megabytes (with the estimate in MB); texsynth::Cancelled when *cancel is raised.
RoundSynthesisContext build_round_context(const RoundMeshInput& mesh, const RoundContextParams& params);

// Borrowed sample pixels, see the conventions above.
struct RoundSample {
  const float* pixels = nullptr;  // height*width*channels
  int32_t width = 0, height = 0, channels = 0;
};

struct RoundSynthParams {
  uint64_t seed = 0;
  int random_candidates = 2;  // coarsest level, per sample pixel of surface (0..kRoundMaxRandomCandidates)
  int dist_range = 2;         // finer levels: the (2·dist_range + 1)² pixels around the prediction (0..8)
  bool tileable = false;      // the sample wraps: reads and candidates wrap around
  // Adaptive top size (§5.2.2): the candidate cuts start at this size. The paper starts at 3x3 (8
  // neighbours); our ring 1 has 4 points, and cutting on them alone ends at T = 1 for ~80 % of the
  // points. Starting at 2 (16 points) measured 10-40 % lower nearest-patch distances on moss, bark
  // and blobs (bench_round); 1 = the literal paper.
  int min_top_size = 2;
  // Metric variant for comparisons: 0 = adaptive; k >= 1 = fixed T = min(k, last coloured ring).
  int fixed_top_size = 0;
  // Coarsest level only (when there is more than one): candidates and copied colours come from the
  // sample blurred by this Gaussian sigma (that level's pixels) plus coarse_sharp_share of the sharp
  // sample, so a thin feature half a pixel off does not cost twice its energy where the field turns
  // (round_neighbourhoods.md, "Sparse structure"). 0 = the sharp sample.
  double coarse_blur = 1.5;
  double coarse_sharp_share = 0.1;
  double max_megabytes = kRoundDefaultMaxMegabytes;  // context + this call
  const std::atomic<bool>* cancel = nullptr;
  std::atomic<float>* progress = nullptr;  // 0..1 while the call runs (optional)
};

struct RoundLevelStats {
  int32_t points = 0;
  double seconds = 0;
  double candidates_per_point = 0;
  double invalid_ring_fraction = 0;     // from the context
  double uncoloured_template_fraction = 0;  // template points without colour when their point was synthesized
  std::vector<int64_t> top_size_histogram;  // [T] for T = 0..K (0: no coloured ring point)
  int64_t reseeds = 0;                  // coarsest level: points started without coloured neighbours
};

struct RoundSynthStats {
  double seconds_prepare = 0;  // fields, pyramid, sample neighbourhoods
  double seconds_output = 0;   // finest colours, image and margin
  double seconds_total = 0;
  int64_t ring_builds = 0;     // always 0: the rings come from the context
  int64_t undefined_directions = 0;  // points whose field was undefined (fallback used)
  int32_t sample_width = 0, sample_height = 0;  // after the crop
  int64_t estimated_bytes = 0;
  std::vector<RoundLevelStats> levels;  // [0] = finest
};

struct RoundSynthResult {
  int32_t channels = 0;
  int32_t num_points = 0;           // finest-level points
  std::vector<int32_t> point_id;    // texel index (image) or vertex (vertices), per point
  std::vector<float> colour;        // num_points*channels
  std::vector<float> source;        // num_points*2, finest sample pixels
  // Image target: height*width*channels (rows in texel order, row 0 at v = 0) with the bake margin
  // filled from the nearest covered texel, and height*width mask (1 = covered texel, 2 = margin).
  std::vector<float> image;
  std::vector<uint8_t> mask;
  RoundSynthStats stats;
};

// directions: context.num_vertices*3 floats, the texture's up per vertex (zero = undefined: the
// nearest defined vertex's along mesh edges, else world +Z, else +Y projected). Throws
// std::invalid_argument for a bad sample (channels not 3 or 4, NaN/inf pixels, smaller than the
// coarsest neighbourhood: (2K + 1)·2^(levels-1) pixels per side), non-finite directions,
// parameters out of range or memory above max_megabytes; texsynth::Cancelled when *cancel is raised
// (nothing is returned).
RoundSynthResult synthesize_round(const RoundSynthesisContext& context, const RoundSample& sample,
                                  const float* directions, const RoundSynthParams& params);

// build_round_rings calls made by build_round_context in this process (synthesize_round makes none).
int64_t round_context_ring_builds();

// Template of K rings (round_neighbourhoods.md, "Rings"): ring m holds the 8m - 4 crossings of the circle
// of radius m with the integer grid (fewer only at Pythagorean radii, m >= 5), as offsets (x, y) in sample
// pixels, ascending angle from +x, rings in order. ring_start has K + 1 entries.
struct RoundTemplate {
  int rings = 0;
  std::vector<int> ring_start;
  std::vector<float> dx, dy, angle;
  int size() const { return int(dx.size()); }
};
RoundTemplate round_template(int rings);

}  // namespace texsynth
