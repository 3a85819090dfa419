// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Texton-string patch synthesis per polygon (Magda & Kriegman 2003, §3.2–3.3).
//
// Every polygon gets one similarity map into the ORIGINAL sample: rotation and scale from the
// shared face frame (face_frame.hpp: averaged orientation, scale × mean vertex multiplier),
// translation found by search. Faces are grown breadth-first over shared edges from a seeded
// random face per face-connected component, so each searched face touches a textured one.
//
// Search (§3.2.2): along every edge shared with a textured neighbour, points at texel spacing of
// the new face's texture space are mapped into the neighbour's mapping (both maps are affine on
// the edge, so that is linear interpolation of the edge's texel ends) and the label of the texel
// there is recorded with its offset from the face's corner 0: the texton string S.
// Origins are searched on the integer grid shifted by the fractional part of the origin the first
// neighbour predicts, so exact continuation is one of the candidates. Offsets are stored as
// floor(phase + offset), making label look-ups exact integer additions. Voting N[B[S_t[k]] - S_o[k]]
// (Fig. 4) by at most max_vote_points string points, the rarest textons first (small buckets are
// the most telling and the cheapest), within a budget of max_votes bucket entries (one point with a
// strided bucket when even its bucket is larger), into sparse uint8 counters reset through a
// touched list, gives the top_m origins (count ties broken by a seeded hash); Eq. 2 over the FULL
// string picks among them, uniformly at random among near-ties (E <= E_min·(1 + tie_tolerance)).
// Candidates keep the whole polygon inside the sample (wrap when tileable).
// Before voting, the origins exactly continuing each textured neighbour are scored with Eq. 2 and
// the best taken when below SearchParams::coherence_threshold (k-coherence); regions grown in
// parallel: TextonSynthParams::seeds_per_component.
//
// Blend sets (replaces the paper's edge blending, §3.3.1, whose attenuated seams stay visible):
//  - every vertex v takes the mapping of its incident polygon textured first (its owner). The
//    mapping's value at v is v's texel there; at a neighbour w it adds the edge v -> w unfolded in
//    the owner's frame (direction of its projection, full length); at a quad's opposite corner it
//    completes the parallelogram. The values depend on the edge alone, not on the polygon.
//  - S = 4 sets per corner. Corner i of a blended polygon has weight 1 on set kCornerSet[n-3][i]
//    (triangles 0, 1, 3; quads 0..3), holding its vertex's mapping over the polygon. Blender
//    interpolates the one-hot weights into barycentric-like λ; on an edge only the edge's two
//    vertices' mappings have weight, with the same values on both sides: the blend is continuous.
//  - the shader (shading.py) shows the polygon's own patch (base UV) in its middle and fades to
//    Σ λ_k · set_k toward the edges, over a distance read from λ: 1 − max(λ_a + λ_b) over the
//    polygon's edges (a, b). Triangles use sets 0, 1, 3 so that those channel pairs never include
//    (0, 2), the diagonal Blender splits quads along.
//  - a polygon is blended when any of its edges is (interior, blend, Φ test passed). Unblended
//    polygons and n-gons (n > 4) get weight 0 everywhere: their own patch only.
//  - With blend = false, S = 1 (the base mapping, weight 1), as the jump-map method.
// Search (E_t, texton strings) is unchanged: blending only hides what the search could not match.
// E_t per edge (§3.3.2): mean Euclidean colour distance between the two sides' base mappings at
// points spaced one texel along the edge (bilinear sample look-up, texel centres at +0.5, clamped
// or wrapped). Boundary edges: 0; non-manifold edges: max over (first face, other face) pairs.
// Φ = λ·E_t·d/‖v − m‖ (Eq. 3–4), d = edge length, m = edge midpoint, v = camera (object space).
#include <atomic>
#include <cstdint>
#include <limits>
#include <vector>

#include "texsynth/common/uninitialized_vector.hpp"
#include "texsynth/mesh/mesh.hpp"
#include "texsynth/mesh/mesh_edges.hpp"
#include "texsynth/preprocess/preprocessed.hpp"
#include "texsynth/synth/corner_maps.hpp"

namespace texsynth {

// Blend set of corner i of a blended triangle (kCornerSet[0]) or quad (kCornerSet[1]).
constexpr int32_t kCornerSet[2][4] = {{0, 1, 3, -1}, {0, 1, 2, 3}};

// A sample image as given to preprocess: height*width*channels floats, row 0 = top.
struct SampleImage {
  const float* pixels = nullptr;
  int32_t width = 0, height = 0, channels = 0;
};

// E_t per edge for ANY per-corner base UVs (Blender UVs into the sample). Throws
// std::invalid_argument on non-finite UVs or pixels.
std::vector<float> edge_continuity_error(const Mesh& mesh, const MeshEdges& edges, const float* base_uv,
                                         const SampleImage& sample, bool tileable);

struct SearchParams {
  int top_m = 16;            // candidates refined with Eq. 2 (1..64)
  int max_vote_points = 16;  // string points that vote, rarest textons first (1..255); Eq. 2 uses all
  int max_votes = 1024;      // vote budget per search (bucket entries visited); >= 1
  double tie_tolerance = 0.05;  // relative Eq. 2 tolerance for the random near-tie choice (>= 0)
  // Coherent candidates (k-coherence style): the origins that exactly continue each textured
  // neighbour are tried first; the best is taken without voting when its Eq. 2 error per string
  // point is below coherence_threshold × the mean texton distance. 0 = off (always vote); [0, 1e6].
  // 0.5: chosen by bench_texton_speed.py (E_t falls as the threshold rises, speed-up levels off).
  double coherence_threshold = 0.5;
  // A face no vote places inside a non-tileable sample takes the origin of least Eq. 2 error in its range
  // (texton_strings.md, "Fallback faces"); false = the neighbour's continuation clamped into the sample, as
  // before (kept to measure the difference).
  bool fallback_search = true;
};

struct TextonSynthParams {
  double scale = 0.0;  // texels per object unit (> 0)
  uint64_t seed = 0;
  bool blend = true;
  const float* scale_multiplier = nullptr;  // optional, num_vertices floats > 0 (borrowed)
  bool allow_oversized = false;
  SearchParams search;
  // Parallel growth: each face-connected component of at least 2 × kMinRegionFaces faces gets up to
  // this many seeds (one per kMinRegionFaces faces), chosen from the seed alone; the regions they
  // reach first (multi-source breadth-first) grow in parallel over their interior faces, then the
  // faces on region borders are grown sequentially, matching both sides. 1 = one seed, sequential
  // (the original growth); [1, 4096]. Default 1: on the shared 2-core benchmark machine no second
  // core was free (1 and 2 threads ran equally fast) and 16 regions cost ~5-9% CPU (README).
  int seeds_per_component = 1;
  // Blending metric: with has_camera, edge_phi = λ·E_t·d/‖v − m‖; with a finite blend_threshold
  // (needs the camera) only edges with Φ > threshold are blended.
  bool has_camera = false;
  double camera[3] = {0, 0, 0};
  double blend_threshold = std::numeric_limits<double>::quiet_NaN();
  double lambda = 1.0;
  const std::atomic<bool>* cancel = nullptr;  // raised -> texsynth::Cancelled (checked every few ms)
};

struct TextonSynthStats {
  int64_t faces = 0, vertices = 0, corners = 0, components = 0;  // components: face-connected
  int64_t searched_faces = 0;    // faces placed by the texton-string search
  int64_t fallback_faces = 0;    // faces with textured neighbours but no valid voted origin
  int64_t coherent_faces = 0;    // searched faces that took a neighbour's continuation without voting
  int64_t regions = 0;           // growth regions (seeds) over all components
  int64_t border_faces = 0;      // faces grown after the parallel region pass (region borders)
  int64_t oversized_faces = 0;
  double max_oversize_ratio = 0;
  int64_t blended_edges = 0;
  int64_t clipped_blend_sets = 0;  // blended polygons where a vertex mapping leaves the sample (clamped there)
  double seconds = 0;
  // Phases within `seconds`: edge table, face frames, growth, base UVs + E_t + Φ, blend sets.
  double seconds_edges = 0, seconds_faces = 0, seconds_grow = 0, seconds_error = 0, seconds_blend = 0;
};

struct TextonSynthResult {
  CornerMaps maps;
  TextonSynthStats stats;
  MeshEdges edges;
  std::vector<float> edge_error;       // E_t per edge
  std::vector<float> edge_phi;         // Φ per edge, NaN without a camera
  std::vector<uint8_t> edge_blended;   // 1 when the edge is blended (interior, blend, Φ test passed)
  std::vector<int32_t> face_region;    // per polygon: its growth region, -1 when grown in the border pass
};

// Faces per seed of the parallel growth (see TextonSynthParams::seeds_per_component).
constexpr int32_t kMinRegionFaces = 256;

// `orientation`: num_vertices*3 unit tangent "up" vectors (compute_orientation_field).
// `sample`: the image given to preprocess (same width/height), for E_t.
// Throws std::invalid_argument on bad parameters, an inconsistent Preprocessed or sample, or
// oversized faces (unless allow_oversized); texsynth::Cancelled when params.cancel is raised.
TextonSynthResult synthesize_texton(const Preprocessed& pre, const Mesh& mesh, const float* orientation,
                                    const SampleImage& sample, const TextonSynthParams& params);

// Number of blend sets synthesize_texton writes: 4 with params.blend, else 1.
inline int32_t texton_blend_sets(bool blend) { return blend ? 4 : 1; }

// The same, writing the corner maps into caller buffers (e.g. numpy arrays): out.num_corners must
// be mesh.num_corners and out.num_blend_sets texton_blend_sets(params.blend). Every element of the
// buffers is written (no zero-filled temporaries); the result's `maps` stays empty.
TextonSynthResult synthesize_texton(const Preprocessed& pre, const Mesh& mesh, const float* orientation,
                                    const SampleImage& sample, const TextonSynthParams& params,
                                    const CornerMapsView& out);

// ---- search primitives (exposed for tests and benchmarks)

// Texton string with integer offsets relative to the searched integer origin.
struct TextonString {
  std::vector<int32_t> label, dx, dy;
  void clear() { label.clear(), dx.clear(), dy.clear(); }
  size_t size() const { return label.size(); }
};

// Appends the points of one edge: o_a, o_b = edge ends as offsets from the new face's corner 0
// (its texture space), t_a, t_b = the same vertices in the neighbour's texel coordinates,
// phase = fractional origin shift in [0, 1)². Labels are read at the nearest texel (clamped, or
// wrapped when the Preprocessed is tileable).
void append_edge_string(const Preprocessed& pre, const float o_a[2], const float o_b[2], const float t_a[2],
                        const float t_b[2], const float phase[2], TextonString& out);

// Inclusive integer origin range; wrap = tileable (the range is then the whole sample).
struct OriginRange {
  int32_t x0 = 0, x1 = -1, y0 = 0, y1 = -1;
  bool wrap = false;
};

// Eq. 2: Σ_k dist(τ[origin + S_o[k]], S_t[k]) (look-ups clamped, or wrapped when range.wrap).
double string_error(const Preprocessed& pre, const TextonString& s, int32_t x, int32_t y, bool wrap);

// Coherent candidates: among `count` origins (x, y pairs; outside a non-wrapping range skipped),
// the one with the lowest Eq. 2 error (first on ties) when that error is < max_error; false when
// none is. Stops summing a candidate as soon as it reaches the best so far.
bool coherent_origin(const Preprocessed& pre, const TextonString& s, const int32_t* xy, int count,
                     const OriginRange& range, double max_error, int32_t& x, int32_t& y, double& error);

// Voting + top-m + Eq. 2 search with reusable scratch (one per thread). Not thread-safe.
class TextonSearch {
 public:
  explicit TextonSearch(const Preprocessed& pre);
  // Returns false when no string point votes for an origin inside `range`.
  bool search(const TextonString& s, const OriginRange& range, const SearchParams& params, uint64_t tie_seed,
              int32_t& x, int32_t& y, double& error);

 private:
  const Preprocessed& pre_;
  int32_t stride_ = 0;
  std::vector<uint8_t> counts_;        // (W+2)*(H+2), origin (x, y) at (y+1)*stride + x+1 (<= 255 voters)
  std::vector<int32_t> touched_;
  std::vector<uint32_t> voters_;
  std::vector<int16_t> bucket_x_, bucket_y_;  // per bucket_pixels entry
};

}  // namespace texsynth
