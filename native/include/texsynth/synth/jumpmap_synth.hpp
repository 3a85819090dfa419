// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Jump-map texture synthesis on a mesh (Zelinka & Garland 2003, §4.1–4.4).
//
// Texture space is texel space of the ORIGINAL sample (x right, y down, pixel (x, y) covers
// [x, x+1) × [y, y+1)); outputs are converted to Blender UVs (x / W, 1 - y / H).
// Tangent frame per vertex: up = orientation u, right = u × n. (The paper's v = n × u would
// mirror the texture when seen from outside; right = u × n keeps it unmirrored.) An edge or face
// offset e maps to texel offset (e·right, -e·up) × scale × multiplier.
//
// Blend sets (per polygon, S = 3 when every polygon is a triangle, else 4):
//  - n ≤ S corners: set k < n is the mapping of corner k's vertex v: v's address plus, at the two
//    corners next to k, the edge unfolded into v's tangent frame (direction of its tangent
//    projection, full length × scale × v's multiplier); a quad's opposite corner completes the
//    parallelogram. Those values depend on the edge only, so two polygons sharing an edge (a, b)
//    blend the same two mappings with the same weights along it: the blend is continuous across
//    every edge (C0), also on curved meshes where polygon frames differ.
//    Corner i has the one-hot weight of set i; sets k ≥ n (triangles in a mesh with quads) repeat
//    the base mapping with weight 0 everywhere. The base mapping uses the polygon frame (face_frame.hpp),
//    an exact similarity of the polygon.
//  - n > S corners (n-gons): topology is never changed. Corner i has the one-hot weight of set
//    (i·S)/n, so the corners form S contiguous runs; set k is grown from the first corner of run k,
//    ceil(k·n/S), in the polygon frame. Blender interpolates one-hot corner weights into a partition of unity over the
//    polygon, so Σ weights = 1 everywhere and the shader's cross-fade stays correct.
// With blend = false, S = 1: the single set is the base mapping with weight 1.
#include <atomic>
#include <cstdint>
#include <vector>

#include "texsynth/mesh/mesh.hpp"
#include "texsynth/preprocess/preprocessed.hpp"
#include "texsynth/synth/corner_maps.hpp"

namespace texsynth {

struct JumpSynthParams {
  double scale = 0.0;             // texels per object unit (> 0)
  double jump_rate = 20.0;        // desired mean texels between jumps (> 0)
  uint64_t seed = 0;
  bool blend = true;
  const float* scale_multiplier = nullptr;  // optional, num_vertices floats > 0 (borrowed)
  bool allow_oversized = false;
  // Continuation weights ramp linearly from 0 at the sample border to full at this distance
  // (texels); 0 = no ramp; < 0 = automatic (5% of the smaller sample side, at least 1). Ignored
  // when tileable.
  double border_ramp = -1.0;
  // Draws from the selection table by rejection (see walk()); after this many rejected draws the
  // exact filtered table is built. 0 = always build the exact table (slower, same distribution).
  int max_rejection_draws = 8;
  const std::atomic<bool>* cancel = nullptr;  // raised by another thread: throws texsynth::Cancelled
  // Benchmark/test switch: the previous pass structure (validity boxes gathered per vertex from
  // each polygon's data, output pages first touched by the corner pass). Same outputs either way.
  bool baseline_passes = false;
};

struct SynthStats {
  int64_t faces = 0, vertices = 0, corners = 0, components = 0;
  int64_t jumps = 0;               // vertices whose address came from a jump entry
  int64_t fallback_vertices = 0;   // vertices with synthesized neighbours but no valid candidate
  int64_t fallback_faces = 0;      // faces with at least one such vertex (likely visible seams)
  int64_t oversized_faces = 0;     // faces whose texture-space extent exceeds the sample
  double max_oversize_ratio = 0;   // max over faces of extent / sample side (≤ 1 when none)
  double seconds = 0;
  // Wall seconds of the phases within `seconds`: frames + face measuring (validity boxes), the
  // order and walk (serial), the corner output.
  double seconds_faces = 0, seconds_walk = 0, seconds_corners = 0;
};

struct JumpSynthResult {
  CornerMaps maps;
  SynthStats stats;
  UninitializedVector<float> vertex_address;  // num_vertices*2 texel coordinates (NaN for loose vertices)
};

// Throws std::invalid_argument for bad parameters, an inconsistent Preprocessed, an orientation
// array with non-finite values, or oversized faces (unless allow_oversized; message gives counts);
// texsynth::Cancelled when *params.cancel is raised (checked every few thousand vertices/faces).
JumpSynthResult synthesize_jumpmap(const Preprocessed& pre, const Mesh& mesh, const float* orientation,
                                   const JumpSynthParams& params);
// Same, writing the corner outputs into `out` (result.maps stays empty). out.num_corners must be
// mesh.num_corners and out.num_blend_sets jumpmap_blend_sets(...), with non-null buffers
// (when there are corners).
JumpSynthResult synthesize_jumpmap(const Preprocessed& pre, const Mesh& mesh, const float* orientation,
                                   const JumpSynthParams& params, const CornerMapsView& out);
// S for a mesh whose polygon sizes are poly_sizes[0..num_polys): 1 without blending, 3 when every
// polygon is a triangle, else 4.
int32_t jumpmap_blend_sets(const int32_t* poly_sizes, int32_t num_polys, bool blend);

// §4.1 region-growing order over vertices that have corners: per component (in id order), from a
// seed vertex picked deterministically from `seed`, repeatedly the unsynthesized vertex with the
// greatest proportion of synthesized neighbours. Proportions are quantised to 1/kOrderLevels
// (bucket queue, O(E)); ties go to the most recently raised vertex.
constexpr int kOrderLevels = 32;
struct VertexOrder {
  std::vector<int32_t> order;            // vertices in synthesis order
  std::vector<int32_t> component_start;  // order[component_start[c]] is component c's seed; size = components + 1
};
VertexOrder region_growing_order(const Mesh& mesh, uint64_t seed, const std::atomic<bool>* cancel = nullptr);
// The same order written into out[0 .. count) (room for mesh.num_vertices entries), for a consumer
// on another thread: the number of final entries is stored in `ready` (release) as the order grows,
// in batches, and once more at the end. When ordered_neighbours is given (same room), bit k of
// ordered_neighbours[i] is set when the k-th neighbour (k < 32) of out[i] comes before it in the
// order. Returns count.
int32_t stream_region_growing_order(const Mesh& mesh, uint64_t seed, int32_t* out, uint32_t* ordered_neighbours,
                                    std::atomic<int32_t>& ready, const std::atomic<bool>* cancel = nullptr);
// Baseline for benchmarks: the same rule with exact proportions and a std::priority_queue.
VertexOrder region_growing_order_heap(const Mesh& mesh, uint64_t seed, const std::atomic<bool>* cancel = nullptr);

}  // namespace texsynth
