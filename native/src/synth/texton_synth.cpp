// SPDX-License-Identifier: GPL-3.0-or-later
// Texton-string patch synthesis per face, edge blending and the blending metric (Magda & Kriegman
// §3.2–3.3). See texton_synth.hpp for the conventions.
#include "texsynth/synth/texton_synth.hpp"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <system_error>
#include <thread>
#include <utility>

#include "texsynth/common/errors.hpp"
#include "texsynth/common/prefault.hpp"
#include "texsynth/common/rng.hpp"
#include "texsynth/common/threads.hpp"
#include "texsynth/common/uninitialized_vector.hpp"
#include "texsynth/mesh/vec_math.hpp"
#include "texsynth/synth/face_frame.hpp"

namespace texsynth {
namespace {

constexpr double kMaxOffset = 1e9;

void validate_textons(const Preprocessed& pre) {
  if (pre.width <= 0 || pre.height <= 0 || int64_t(pre.width) * pre.height > std::numeric_limits<int32_t>::max())
    throw std::invalid_argument("preprocessed sample has an invalid size " + std::to_string(pre.width) + "x" +
                                std::to_string(pre.height));
  const int64_t pixels = int64_t(pre.width) * pre.height;
  const int64_t K = pre.num_textons;
  if (K < 1 || K > 65535) throw std::invalid_argument("preprocessed sample has " + std::to_string(K) + " textons");
  if (int64_t(pre.texton_map.size()) != pixels || int64_t(pre.texton_distances.size()) != K * K ||
      int64_t(pre.bucket_start.size()) != K + 1 || int64_t(pre.bucket_pixels.size()) != pixels)
    throw std::invalid_argument("preprocessed texton data has inconsistent sizes (texton map, distance table, buckets)");
  for (float d : pre.texton_distances)
    if (!std::isfinite(d) || d < 0.f) throw std::invalid_argument("preprocessed texton distance table has a negative or non-finite entry");
  if (pre.bucket_start[0] != 0 || pre.bucket_start[K] != pixels)
    throw std::invalid_argument("preprocessed bucket array does not cover every pixel");
  for (int64_t t = 0; t < K; ++t)
    if (pre.bucket_start[t + 1] < pre.bucket_start[t]) throw std::invalid_argument("preprocessed bucket starts decrease");
  for (int64_t p = 0; p < pixels; ++p)
    if (pre.texton_map[p] < 0 || pre.texton_map[p] >= K)
      throw std::invalid_argument("preprocessed texton map has label " + std::to_string(pre.texton_map[p]) +
                                  " at pixel " + std::to_string(p) + ", outside [0, " + std::to_string(K) + ")");
  for (int64_t t = 0; t < K; ++t) {
    for (int32_t i = pre.bucket_start[t]; i < pre.bucket_start[t + 1]; ++i) {
      const int32_t p = pre.bucket_pixels[i];
      if (p < 0 || p >= pixels || pre.texton_map[p] != t)
        throw std::invalid_argument("preprocessed bucket " + std::to_string(t) + " lists pixel " + std::to_string(p) +
                                    " whose texton label differs");
    }
  }
}

void validate_sample(const Preprocessed& pre, const SampleImage& s) {
  if (s.width != pre.width || s.height != pre.height)
    throw std::invalid_argument("sample_pixels is " + std::to_string(s.width) + "x" + std::to_string(s.height) +
                                " but the preprocessed sample is " + std::to_string(pre.width) + "x" +
                                std::to_string(pre.height) + " (pass the image given to preprocess)");
  if (s.channels < 1 || s.channels > 4) throw std::invalid_argument("sample_pixels must have 1 to 4 channels");
  if (!s.pixels) throw std::invalid_argument("sample_pixels is missing");
  const size_t n = size_t(s.width) * s.height * s.channels;
  for (size_t i = 0; i < n; ++i)
    if (!std::isfinite(s.pixels[i])) throw std::invalid_argument("sample_pixels has NaN or infinite values");
}

void validate_params(const Mesh& m, const float* orientation, const TextonSynthParams& p) {
  if (!std::isfinite(p.scale) || p.scale <= 0 || p.scale > 1e30)
    throw std::invalid_argument("scale (texels per object unit) must be finite, > 0 and <= 1e30");
  if (p.search.top_m < 1 || p.search.top_m > 64) throw std::invalid_argument("top_m must be in [1, 64]");
  if (p.search.max_vote_points < 1 || p.search.max_vote_points > 255)
    throw std::invalid_argument("max_vote_points must be in [1, 255]");
  if (p.search.max_votes < 1) throw std::invalid_argument("max_votes must be >= 1");
  if (!(p.search.tie_tolerance >= 0 && p.search.tie_tolerance <= 1e6))
    throw std::invalid_argument("tie_tolerance must be in [0, 1e6]");
  if (!(p.search.coherence_threshold >= 0 && p.search.coherence_threshold <= 1e6))
    throw std::invalid_argument("coherence_threshold must be in [0, 1e6] (0 = always vote)");
  if (p.seeds_per_component < 1 || p.seeds_per_component > 4096)
    throw std::invalid_argument("seeds_per_component must be in [1, 4096] (1 = one seed, sequential growth)");
  if (!std::isfinite(p.lambda) || p.lambda < 0) throw std::invalid_argument("lambda_ must be finite and >= 0");
  if (p.has_camera && !(std::isfinite(p.camera[0]) && std::isfinite(p.camera[1]) && std::isfinite(p.camera[2])))
    throw std::invalid_argument("camera_position must be finite");
  if (!std::isnan(p.blend_threshold)) {
    if (!std::isfinite(p.blend_threshold)) throw std::invalid_argument("blend_threshold must be finite");
    if (!p.has_camera) throw std::invalid_argument("blend_threshold needs camera_position");
  }
  validate_vertex_inputs(m, orientation, p.scale_multiplier);
}

// Bilinear colour at texel coordinate (x, y); texel centres at +0.5; clamped or wrapped.
void bilinear(const SampleImage& s, bool wrap, double x, double y, float* out) {
  const double fx = x - 0.5, fy = y - 0.5;
  const double x0 = std::floor(fx), y0 = std::floor(fy);
  const double tx = fx - x0, ty = fy - y0;
  const int C = s.channels;
  for (int c = 0; c < C; ++c) out[c] = 0.f;
  for (int corner = 0; corner < 4; ++corner) {
    double qx = x0 + (corner & 1), qy = y0 + (corner >> 1);
    const double w = ((corner & 1) ? tx : 1 - tx) * ((corner >> 1) ? ty : 1 - ty);
    if (wrap) {
      qx -= s.width * std::floor(qx / s.width), qy -= s.height * std::floor(qy / s.height);
      if (qx >= s.width) qx = 0;
      if (qy >= s.height) qy = 0;
    } else {
      qx = std::clamp(qx, 0.0, double(s.width - 1)), qy = std::clamp(qy, 0.0, double(s.height - 1));
    }
    const float* px = s.pixels + (size_t(qy) * s.width + size_t(qx)) * C;
    for (int c = 0; c < C; ++c) out[c] += float(w * px[c]);
  }
}

// Texel coordinates of a corner from a Blender UV.
inline void uv_to_texel(const float* uv, const SampleImage& s, double& x, double& y) {
  x = double(uv[0]) * s.width;
  y = (1.0 - double(uv[1])) * s.height;
}

// Corner of polygon `poly` (its first occurrence) at vertex v, or -1.
inline int32_t corner_at(const Mesh& m, int32_t poly, int32_t v) {
  const int32_t first = m.poly_starts[poly];
  for (int32_t i = 0; i < m.poly_sizes[poly]; ++i)
    if (m.corner_verts[first + i] == v) return first + i;
  return -1;
}

void validate_base_uv(const float* base_uv, int32_t num_corners) {
  for (int64_t i = 0; i < int64_t(num_corners) * 2; ++i)
    if (!std::isfinite(base_uv[i]) || std::fabs(base_uv[i]) > 1e6f)
      throw std::invalid_argument("base_uv of corner " + std::to_string(i / 2) + " is NaN, infinite or beyond 1e6");
}

// E_t of edge e (see edge_continuity_error): 0 when fewer than two corners use it.
float edge_error_at(const Mesh& m, const MeshEdges& edges, const float* base_uv, const SampleImage& s, bool tileable,
                    int32_t e) {
  const int32_t begin = edges.edge_corner_start[e], end = edges.edge_corner_start[e + 1];
  if (end - begin < 2) return 0.f;
  const int32_t max_points = 4 * std::max(s.width, s.height);
  const int32_t va = edges.vertices[2 * size_t(e)], vb = edges.vertices[2 * size_t(e) + 1];
  auto ends = [&](int32_t corner, double* xy) {
    const int32_t poly = m.corner_poly[corner];
    uv_to_texel(base_uv + 2 * size_t(corner_at(m, poly, va)), s, xy[0], xy[1]);
    uv_to_texel(base_uv + 2 * size_t(corner_at(m, poly, vb)), s, xy[2], xy[3]);
  };
  float ca[4], cb[4];
  double p[4], q[4];
  ends(edges.edge_corners[begin], p);
  float worst = 0.f;
  for (int32_t j = begin + 1; j < end; ++j) {
    ends(edges.edge_corners[j], q);
    const double len = std::max(std::hypot(p[2] - p[0], p[3] - p[1]), std::hypot(q[2] - q[0], q[3] - q[1]));
    const int32_t count = len < 1 ? 1 : len < max_points ? int32_t(std::ceil(len)) : max_points;
    double sum = 0;
    for (int32_t i = 0; i < count; ++i) {
      const double t = (i + 0.5) / count;
      bilinear(s, tileable, p[0] + t * (p[2] - p[0]), p[1] + t * (p[3] - p[1]), ca);
      bilinear(s, tileable, q[0] + t * (q[2] - q[0]), q[1] + t * (q[3] - q[1]), cb);
      double d2 = 0;
      for (int c = 0; c < s.channels; ++c) d2 += double(ca[c] - cb[c]) * (ca[c] - cb[c]);
      sum += std::sqrt(d2);
    }
    worst = std::max(worst, float(sum / count));
  }
  return worst;
}

}  // namespace

std::vector<float> edge_continuity_error(const Mesh& m, const MeshEdges& edges, const float* base_uv,
                                         const SampleImage& s, bool tileable) {
  validate_base_uv(base_uv, m.num_corners);
  const int32_t E = edges.num_edges();
  std::vector<float> error(size_t(E), 0.f);
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, E, 1024), [&](const tbb::blocked_range<int32_t>& r) {
    for (int32_t e = r.begin(); e < r.end(); ++e) error[e] = edge_error_at(m, edges, base_uv, s, tileable, e);
  });
  return error;
}

namespace {

class TextonSynthesizer {
 public:
  TextonSynthesizer(const Preprocessed& pre, const Mesh& m, const float* orientation, const SampleImage& sample,
                    const TextonSynthParams& p)
      : pre_(pre), m_(m), orientation_(orientation), sample_(sample), p_(p), W_(float(pre.width)),
        H_(float(pre.height)), tileable_(pre.params.tileable) {}

  TextonSynthResult run(const CornerMapsView& out) {
    TextonSynthResult r;
    using Clock = std::chrono::steady_clock;
    Clock::time_point t = Clock::now();
    auto lap = [&t] {
      const Clock::time_point now = Clock::now();
      const double seconds = std::chrono::duration<double>(now - t).count();
      t = now;
      return seconds;
    };
    throw_if_cancelled(p_.cancel);
    r.edges = build_mesh_edges(m_);
    r.stats.seconds_edges = lap();
    throw_if_cancelled(p_.cancel);
    // The growth's serial component search (breadth-first, ~15 % of the growth) alongside the
    // parallel face pass: both need only the mesh and its edges.
    find_twins(r.edges);
    tbb::parallel_invoke([&] { measure_faces(r.stats); }, [&] { collect_components(r.edges); });
    check_oversized_faces(r.stats.oversized_faces, r.stats.max_oversize_ratio, m_.num_polys, pre_.width, pre_.height,
                          p_.scale, p_.allow_oversized);
    r.stats.seconds_faces = lap();
    {
      // The growth is serial (one region) or ends with a serial border pass: meanwhile a second
      // thread touches the output pages, so the kernel zeroes them off the critical path.
      std::atomic<bool> stop{false};
      std::thread prefaulter;
      if (usable_threads() > 1 && p_.seeds_per_component <= 1) {
        try {
          prefaulter = std::thread([&] { prefault_outputs(out, stop); });
        } catch (const std::system_error&) {  // no thread: the passes below fault the pages in
        }
      }
      struct Join {
        std::thread& thread;
        std::atomic<bool>& stop;
        ~Join() {
          if (!thread.joinable()) return;
          stop.store(true, std::memory_order_relaxed);
          thread.join();
        }
      } join{prefaulter, stop};
      grow(r.edges, r.stats, r.face_region);
    }
    r.stats.seconds_grow = lap();
    throw_if_cancelled(p_.cancel);
    write_base(out);
    r.edge_error = edge_continuity_error(m_, r.edges, out.base_uv, sample_, tileable_);
    throw_if_cancelled(p_.cancel);
    blending_metric(r);
    r.stats.seconds_error = lap();
    write_blend_sets(r, out);
    r.stats.seconds_blend = lap();
    throw_if_cancelled(p_.cancel);
    r.stats.faces = m_.num_polys;
    r.stats.vertices = m_.num_vertices;
    r.stats.corners = m_.num_corners;
    return r;
  }

 private:
  // Faults the output buffers' pages in (see the growth in run()); stops early when `stop` or
  // cancel is raised.
  void prefault_outputs(const CornerMapsView& out, const std::atomic<bool>& stop) const {
    const size_t L = size_t(out.num_corners), S = size_t(out.num_blend_sets);
    auto stopped = [&] {
      return stop.load(std::memory_order_relaxed) || (p_.cancel && p_.cancel->load(std::memory_order_relaxed));
    };
    prefault_pages(out.base_uv, 2 * L, stopped);
    prefault_pages(out.blend_uv, out.packed_pairs ? (S + 1) / 2 * L * 4 : S * L * 2, stopped);
    prefault_pages(out.blend_weights, S * L, stopped);
  }

  // Pass 1 (parallel): per-corner offsets in the face frame, per-face bounding boxes.
  void measure_faces(TextonSynthStats& st) {
    offset_.resize(size_t(m_.num_corners) * 2);
    box_.resize(size_t(m_.num_polys) * 4);
    frame_.resize(size_t(m_.num_polys));
    auto up_of = [&](int32_t v) {
      V3 n = v3(&m_.normals[3 * size_t(v)]);
      return normalized_or(project_to_plane(v3(orientation_ + 3 * size_t(v)), n), any_perpendicular(n));
    };
    tbb::parallel_for(tbb::blocked_range<int32_t>(0, m_.num_polys, 4096), [&](const tbb::blocked_range<int32_t>& r) {
      throw_if_cancelled(p_.cancel);
      for (int32_t poly = r.begin(); poly < r.end(); ++poly) {
        float* xy = &offset_[2 * size_t(m_.poly_starts[poly])];
        frame_[poly] = face_frame(m_, poly, up_of, p_.scale, p_.scale_multiplier);
        face_texel_offsets(m_, poly, frame_[poly], xy);
        float* b = &box_[4 * size_t(poly)];
        b[0] = b[1] = b[2] = b[3] = 0.f;
        for (int32_t i = 0; i < m_.poly_sizes[poly]; ++i) {
          b[0] = std::min(b[0], xy[2 * i]), b[1] = std::min(b[1], xy[2 * i + 1]);
          b[2] = std::max(b[2], xy[2 * i]), b[3] = std::max(b[3], xy[2 * i + 1]);
        }
      }
    });
    for (int32_t poly = 0; poly < m_.num_polys; ++poly) {
      const float* b = &box_[4 * size_t(poly)];
      if (!(std::fabs(b[0]) <= kMaxOffset && std::fabs(b[1]) <= kMaxOffset && std::fabs(b[2]) <= kMaxOffset &&
            std::fabs(b[3]) <= kMaxOffset))
        throw std::invalid_argument("scale " + std::to_string(p_.scale) + " makes face " + std::to_string(poly) +
                                    " span more than 1e9 texels");
      const double ratio = std::max((b[2] - b[0]) / W_, (b[3] - b[1]) / H_);
      st.max_oversize_ratio = std::max(st.max_oversize_ratio, ratio);
      if (ratio > 1.0) ++st.oversized_faces;
    }
  }

  // Integer origins keeping the face inside the sample for origin phase `ph` (centred when it can't).
  OriginRange origin_range(int32_t poly, const float ph[2]) const {
    OriginRange r;
    if (tileable_) {
      r.wrap = true, r.x1 = pre_.width - 1, r.y1 = pre_.height - 1;
      return r;
    }
    const float* b = &box_[4 * size_t(poly)];
    auto axis = [](float lo, float hi, float size, float phase, int32_t& a0, int32_t& a1) {
      a0 = int32_t(std::ceil(-lo - phase)), a1 = int32_t(std::floor(size - hi - phase));
      if (a1 < a0) a0 = a1 = int32_t(std::floor(0.5f * (size - hi - lo) - phase));
    };
    axis(b[0], b[2], W_, ph[0], r.x0, r.x1);
    axis(b[1], b[3], H_, ph[1], r.y0, r.y1);
    return r;
  }

  struct GrowCounts {
    int64_t searched = 0, fallback = 0, coherent = 0;
    void add(const GrowCounts& o) { searched += o.searched, fallback += o.fallback, coherent += o.coherent; }
  };

  // Per corner, the other corner on its edge when the edge has exactly two (the growth's serial
  // passes then take one look-up instead of the edge's list, far away in memory); kNoTwin on a
  // border or zero-length edge, kSharedEdge when more than two polygons share it.
  static constexpr int32_t kNoTwin = -1, kSharedEdge = -2;
  void find_twins(const MeshEdges& edges) {
    twin_.resize(size_t(m_.num_corners));
    tbb::parallel_for(tbb::blocked_range<int32_t>(0, m_.num_corners, 16384), [&](const tbb::blocked_range<int32_t>& r) {
      throw_if_cancelled(p_.cancel);
      for (int32_t c = r.begin(); c < r.end(); ++c) {
        const int32_t e = edges.corner_edge[c];
        const int32_t count = e < 0 ? 0 : edges.edge_corner_start[e + 1] - edges.edge_corner_start[e];
        const int32_t* corners = e < 0 ? nullptr : edges.edge_corners.data() + edges.edge_corner_start[e];
        twin_[c] = count == 2 ? corners[corners[0] == c ? 1 : 0] : count > 2 ? kSharedEdge : kNoTwin;
      }
    });
  }

  // Calls fn(c2) for each corner c2 on corner c's edge except c, in ascending order.
  template <class Fn>
  void for_each_edge_corner(const MeshEdges& edges, int32_t c, Fn&& fn) const {
    const int32_t twin = twin_[c];
    if (twin >= 0) return fn(twin);
    if (twin == kNoTwin) return;
    const int32_t e = edges.corner_edge[c];
    for (int32_t j = edges.edge_corner_start[e]; j < edges.edge_corner_start[e + 1]; ++j)
      if (edges.edge_corners[j] != c) fn(edges.edge_corners[j]);
  }

  template <class Fn>
  void for_each_neighbour(const MeshEdges& edges, int32_t poly, Fn&& fn) const {
    const int32_t first = m_.poly_starts[poly];
    for (int32_t i = 0; i < m_.poly_sizes[poly]; ++i)
      for_each_edge_corner(edges, first + i, [&](int32_t c) {
        if (m_.corner_poly[c] != poly) fn(m_.corner_poly[c]);
      });
  }

  // The face-connected components in the order the growth meets them (that of their lowest face),
  // each in breadth-first order from that face: component k is component_faces_[
  // component_start_[k] .. component_start_[k + 1]).
  void collect_components(const MeshEdges& edges) {
    const int32_t F = m_.num_polys;
    std::vector<uint8_t> seen(size_t(F), 0);
    component_faces_.clear();
    component_faces_.reserve(size_t(F));
    component_start_.assign(1, 0);
    for (int32_t start = 0; start < F; ++start) {
      if (seen[start]) continue;
      component_faces_.push_back(start);
      seen[start] = 1;
      for (size_t h = size_t(component_start_.back()); h < component_faces_.size(); ++h) {
        if ((h & 65535) == 65535) throw_if_cancelled(p_.cancel);
        for_each_neighbour(edges, component_faces_[h], [&](int32_t g) {
          if (!seen[g]) seen[g] = 1, component_faces_.push_back(g);
        });
      }
      component_start_.push_back(int32_t(component_faces_.size()));
    }
  }
  int32_t num_components() const { return int32_t(component_start_.size()) - 1; }
  const int32_t* component_begin(int32_t k) const { return component_faces_.data() + component_start_[k]; }
  uint32_t component_size(int32_t k) const { return uint32_t(component_start_[k + 1] - component_start_[k]); }

  // Pass 2: breadth-first growth and search (one RNG stream per face).
  void grow(const MeshEdges& edges, TextonSynthStats& st, std::vector<int32_t>& face_region) {
    texel_.assign(size_t(m_.num_corners) * 2, 0.f);
    textured_.assign(size_t(m_.num_polys), 0);
    placed_at_.assign(size_t(m_.num_polys), std::numeric_limits<int32_t>::max());
    face_region.assign(size_t(m_.num_polys), -1);
    double sum = 0;
    for (float d : pre_.texton_distances) sum += d;
    coherence_bound_ = p_.search.coherence_threshold * sum / double(pre_.texton_distances.size());
    GrowCounts counts;
    if (p_.seeds_per_component <= 1)
      grow_sequential(edges, st, counts, face_region);
    else
      grow_regions(edges, st, counts, face_region);
    st.searched_faces = counts.searched, st.fallback_faces = counts.fallback, st.coherent_faces = counts.coherent;
  }

  // One seed per component, sequential (seeds_per_component = 1).
  void grow_sequential(const MeshEdges& edges, TextonSynthStats& st, GrowCounts& counts,
                       std::vector<int32_t>& face_region) {
    int32_t placed_count = 0;
    std::vector<uint8_t> state(size_t(m_.num_polys), 0);  // 0 new, 1 queued/visited
    std::vector<int32_t> queue;
    queue.reserve(size_t(m_.num_polys));
    TextonSearch search(pre_);
    TextonString string;
    Rng component_rng(p_.seed, 0x636f6d70);  // "comp"
    uint32_t placed = 0;
    for (int32_t k = 0; k < num_components(); ++k) {
      // Grow each face-connected component from a seeded random face in it.
      const int32_t region = int32_t(st.components++);
      ++st.regions;
      queue.assign(1, component_begin(k)[component_rng.below(component_size(k))]);
      state[queue[0]] = 1;
      for (size_t h = 0; h < queue.size(); ++h) {
        // ~200k faces/s: a check every 256 faces is about a millisecond apart.
        if ((++placed & 255) == 0) throw_if_cancelled(p_.cancel);
        const int32_t poly = queue[h];
        place(poly, edges, search, string, counts, false);
        placed_at_[poly] = placed_count++;
        face_region[poly] = region;
        for_each_neighbour(edges, poly, [&](int32_t g) {
          if (state[g] == 0) state[g] = 1, queue.push_back(g);
        });
      }
    }
  }

  // Several seeds per component (see TextonSynthParams::seeds_per_component). Deterministic
  // whatever the thread count: regions are labelled sequentially, a region task reads and writes
  // only its own faces (interior faces have all their neighbours in the region; a seed ignores
  // its neighbours), and the border pass is sequential.
  void grow_regions(const MeshEdges& edges, TextonSynthStats& st, GrowCounts& counts,
                    std::vector<int32_t>& region) {
    const int32_t F = m_.num_polys;
    std::vector<int32_t> seeds, queue;
    Rng component_rng(p_.seed, 0x636f6d70);  // "comp"
    for (int32_t k = 0; k < num_components(); ++k) {
      const int32_t* component = component_begin(k);
      ++st.components;
      const uint32_t size = component_size(k);
      const int32_t wanted = int32_t(std::clamp<int64_t>(size / uint32_t(kMinRegionFaces), 1, p_.seeds_per_component));
      const size_t first_seed = seeds.size();
      // Distinct random faces (the first as the sequential growth picks it); a few draws may collide.
      for (int32_t draw = 0; int32_t(seeds.size() - first_seed) < wanted && draw < 4 * wanted; ++draw) {
        const int32_t f = component[component_rng.below(size)];
        if (region[f] >= 0) continue;
        region[f] = int32_t(seeds.size());
        seeds.push_back(f);
      }
      // Multi-source breadth-first labelling: each face joins the region that reaches it first.
      queue.assign(seeds.begin() + first_seed, seeds.end());
      for (size_t h = 0; h < queue.size(); ++h) {
        if ((h & 65535) == 65535) throw_if_cancelled(p_.cancel);
        const int32_t r = region[queue[h]];
        for_each_neighbour(edges, queue[h], [&](int32_t g) {
          if (region[g] < 0) region[g] = r, queue.push_back(g);
        });
      }
    }
    const int32_t R = int32_t(seeds.size());
    st.regions = R;
    std::vector<uint8_t> interior(size_t(F), 1);
    tbb::parallel_for(tbb::blocked_range<int32_t>(0, F, 8192), [&](const tbb::blocked_range<int32_t>& b) {
      for (int32_t f = b.begin(); f < b.end(); ++f)
        for_each_neighbour(edges, f, [&](int32_t g) { interior[f] = interior[f] && region[g] == region[f]; });
    });
    // Region pass (parallel): each region grows from its seed over its interior faces.
    struct Scratch {
      explicit Scratch(const Preprocessed& pre) : search(pre) {}
      TextonSearch search;
      TextonString string;
      std::vector<int32_t> queue;
    };
    tbb::enumerable_thread_specific<Scratch> scratch([&] { return Scratch(pre_); });
    std::vector<GrowCounts> region_counts(static_cast<size_t>(R));
    std::vector<int32_t> region_placed(size_t(R) + 1, 0);
    std::vector<uint8_t> queued(size_t(F), 0);
    tbb::parallel_for(tbb::blocked_range<int32_t>(0, R, 1), [&](const tbb::blocked_range<int32_t>& b) {
      Scratch& sc = scratch.local();
      for (int32_t r = b.begin(); r < b.end(); ++r) {
        sc.queue.assign(1, seeds[r]);
        queued[seeds[r]] = 1;
        GrowCounts local;  // not region_counts[r]: neighbouring entries share a cache line across threads
        for (size_t h = 0; h < sc.queue.size(); ++h) {
          if ((h & 255) == 255) throw_if_cancelled(p_.cancel);
          const int32_t poly = sc.queue[h];
          place(poly, edges, sc.search, sc.string, local, h == 0);
          placed_at_[poly] = int32_t(h);  // rank within the region; offset below
          for_each_neighbour(edges, poly, [&](int32_t g) {
            if (region[g] == r && interior[g] && !queued[g]) queued[g] = 1, sc.queue.push_back(g);
          });
        }
        region_placed[r + 1] = int32_t(sc.queue.size());
        region_counts[r] = local;
      }
    });
    throw_if_cancelled(p_.cancel);
    for (int32_t r = 0; r < R; ++r) region_placed[r + 1] += region_placed[r], counts.add(region_counts[r]);
    // Growth order (vertex mapping owners): regions in order, then the border pass.
    for (int32_t f = 0; f < F; ++f)
      if (textured_[f]) placed_at_[f] += region_placed[region[f]];
    // Border pass (sequential): breadth-first from the textured faces, in face order.
    int32_t placed_count = region_placed[R];
    TextonSearch& search = scratch.local().search;
    TextonString& string = scratch.local().string;
    queue.clear();
    for (int32_t f = 0; f < F; ++f) {
      if (textured_[f]) continue;
      region[f] = -1;
      bool touches = false;
      for_each_neighbour(edges, f, [&](int32_t g) { touches = touches || textured_[g]; });
      if (touches) queued[f] = 1, queue.push_back(f);
    }
    for (size_t h = 0; h < queue.size(); ++h) {
      if ((h & 255) == 255) throw_if_cancelled(p_.cancel);
      const int32_t poly = queue[h];
      place(poly, edges, search, string, counts, false);
      placed_at_[poly] = placed_count++;
      for_each_neighbour(edges, poly, [&](int32_t g) {
        if (!queued[g]) queued[g] = 1, queue.push_back(g);
      });
    }
    st.border_faces = int64_t(queue.size());
  }

  // Places one face: searched from its textured neighbours, or (seed_face, or none textured) a
  // random origin. Sets its corner texels and textured_.
  void place(int32_t poly, const MeshEdges& edges, TextonSearch& search, TextonString& string, GrowCounts& st,
             bool seed_face) {
    const int32_t first = m_.poly_starts[poly], n = m_.poly_sizes[poly];
    const float* off = &offset_[2 * size_t(first)];
    const uint64_t face_seed = splitmix64(splitmix64(p_.seed ^ 0x7465787430000000ull) + uint64_t(poly));
    const bool coherence = coherence_bound_ > 0;
    constexpr int kMaxCoherent = 8;
    int32_t coherent_xy[2 * kMaxCoherent];
    int num_coherent = 0;
    string.clear();
    bool predicted = false;
    float phase[2] = {0.f, 0.f}, guess[2] = {0.f, 0.f};
    for (int32_t i = 0; i < n && !seed_face; ++i) {
      const int32_t va = m_.corner_verts[first + i];
      const float* oa = off + 2 * i;
      const float* ob = off + 2 * ((i + 1) % n);
      for_each_edge_corner(edges, first + i, [&](int32_t c) {
        const int32_t g = m_.corner_poly[c];
        if (g == poly || !textured(g)) return;
        const int32_t c_next = m_.poly_starts[g] + (c - m_.poly_starts[g] + 1) % m_.poly_sizes[g];
        const bool same = m_.corner_verts[c] == va;
        const float* ta = &texel_[2 * size_t(same ? c : c_next)];
        const float* tb = &texel_[2 * size_t(same ? c_next : c)];
        if (!predicted || (coherence && num_coherent < kMaxCoherent)) {
          // Origin this neighbour predicts: its edge similarity applied to offset 0.
          float q[2], gx, gy;
          edge_similarity(oa, ob, ta, tb, q);
          gx = ta[0] - (q[0] * oa[0] - q[1] * oa[1]);
          gy = ta[1] - (q[1] * oa[0] + q[0] * oa[1]);
          if (!predicted) {
            guess[0] = gx, guess[1] = gy;
            phase[0] = guess[0] - std::floor(guess[0]), phase[1] = guess[1] - std::floor(guess[1]);
            if (!(phase[0] >= 0.f && phase[0] < 1.f)) phase[0] = 0.f;
            if (!(phase[1] >= 0.f && phase[1] < 1.f)) phase[1] = 0.f;
            predicted = true;
          }
          if (coherence) {  // its continuation on this face's origin grid (exact for the first)
            int32_t cx = int32_t(std::floor(std::clamp(gx - phase[0] + 0.5f, -1e9f, 1e9f)));
            int32_t cy = int32_t(std::floor(std::clamp(gy - phase[1] + 0.5f, -1e9f, 1e9f)));
            if (tileable_) cx = wrap_coordinate(cx, pre_.width), cy = wrap_coordinate(cy, pre_.height);
            bool known = false;
            for (int k = 0; k < num_coherent; ++k)
              known = known || (coherent_xy[2 * k] == cx && coherent_xy[2 * k + 1] == cy);
            if (!known) coherent_xy[2 * num_coherent] = cx, coherent_xy[2 * num_coherent + 1] = cy, ++num_coherent;
          }
        }
        append_edge_string(pre_, oa, ob, ta, tb, phase, string);
      });
    }
    const OriginRange range = origin_range(poly, phase);
    int32_t ox = 0, oy = 0;
    double err = 0;
    if (predicted && coherence &&
        coherent_origin(pre_, string, coherent_xy, num_coherent, range, coherence_bound_ * double(string.size()), ox,
                        oy, err)) {
      ++st.searched, ++st.coherent;
    } else if (predicted && search.search(string, range, p_.search, face_seed, ox, oy, err)) {
      ++st.searched;
    } else if (predicted) {  // nothing voted inside the range
      ++st.fallback;
      ox = int32_t(std::floor(std::clamp(guess[0], -1e9f, 1e9f))), oy = int32_t(std::floor(std::clamp(guess[1], -1e9f, 1e9f)));
      if (!range.wrap) {
        ox = std::clamp(ox, range.x0, range.x1), oy = std::clamp(oy, range.y0, range.y1);
        if (p_.search.fallback_search) fallback_origin(string, range, face_seed, ox, oy);
      }
    } else {  // first face of a component or region: a random origin
      Rng rng(face_seed, 0x73656564);  // "seed"
      ox = range.x0 + int32_t(rng.below(uint32_t(range.x1 - range.x0 + 1)));
      oy = range.y0 + int32_t(rng.below(uint32_t(range.y1 - range.y0 + 1)));
    }
    float X = float(ox) + phase[0], Y = float(oy) + phase[1];
    if (tileable_) X -= W_ * std::floor(X / W_), Y -= H_ * std::floor(Y / H_);
    for (int32_t i = 0; i < n; ++i) {
      texel_[2 * size_t(first + i)] = X + off[2 * i];
      texel_[2 * size_t(first + i) + 1] = Y + off[2 * i + 1];
    }
    textured_[poly] = 1;
  }

  // A face no vote placed inside the sample (its origin range is small: a face nearly as large as the sample)
  // takes the origin of least string error (Eq. 2) in the range: every origin of a range up to
  // kFallbackAll, else kFallbackDraws seeded ones, and the clamped continuation (ox, oy) of before. Clamped
  // alone, neighbouring fallback faces all landed on the sample's border: a ladder of near-identical tiles.
  static constexpr int64_t kFallbackAll = 4096;
  static constexpr int kFallbackDraws = 256;
  void fallback_origin(const TextonString& string, const OriginRange& range, uint64_t face_seed, int32_t& ox,
                       int32_t& oy) const {
    const int64_t w = int64_t(range.x1) - range.x0 + 1, h = int64_t(range.y1) - range.y0 + 1;
    if (string.size() == 0 || w < 1 || h < 1) return;
    std::vector<int32_t> xy{ox, oy};
    if (w * h <= kFallbackAll) {
      for (int32_t y = range.y0; y <= range.y1; ++y)
        for (int32_t x = range.x0; x <= range.x1; ++x) xy.push_back(x), xy.push_back(y);
    } else {
      Rng rng(face_seed, 0x66616c6c);  // "fall"
      for (int i = 0; i < kFallbackDraws; ++i) {
        xy.push_back(range.x0 + int32_t(rng.below(uint32_t(w))));
        xy.push_back(range.y0 + int32_t(rng.below(uint32_t(h))));
      }
    }
    int32_t x = ox, y = oy;
    double err = 0;
    if (coherent_origin(pre_, string, xy.data(), int(xy.size() / 2), range, std::numeric_limits<double>::infinity(),
                        x, y, err))
      ox = x, oy = y;
  }

  static int32_t wrap_coordinate(int32_t v, int32_t n) {
    v %= n;
    return v < 0 ? v + n : v;
  }

  bool textured(int32_t poly) const { return textured_[poly] != 0; }

  // Complex ratio q = (tb - ta) / (ob - oa): the similarity taking this face's edge onto the
  // neighbour's texel edge (identity for degenerate edges).
  static void edge_similarity(const float* oa, const float* ob, const float* ta, const float* tb, float* q) {
    const double ex = ob[0] - oa[0], ey = ob[1] - oa[1], fx = tb[0] - ta[0], fy = tb[1] - ta[1];
    const double len2 = ex * ex + ey * ey;
    if (!(len2 > 1e-12)) {
      q[0] = 1.f, q[1] = 0.f;
      return;
    }
    q[0] = float((fx * ex + fy * ey) / len2);
    q[1] = float((fy * ex - fx * ey) / len2);
  }

  void texel_to_uv(float x, float y, float* uv) const {
    if (!tileable_) x = std::clamp(x, 0.f, W_), y = std::clamp(y, 0.f, H_);
    uv[0] = x / W_;
    uv[1] = 1.f - y / H_;
  }

  void write_base(const CornerMapsView& out) const {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, size_t(m_.num_corners), 16384), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t c = r.begin(); c < r.end(); ++c) texel_to_uv(texel_[2 * c], texel_[2 * c + 1], out.base_uv + 2 * c);
    });
  }

  void blending_metric(TextonSynthResult& r) const {
    const int32_t E = r.edges.num_edges();
    r.edge_phi.assign(size_t(E), std::numeric_limits<float>::quiet_NaN());
    r.edge_blended.assign(size_t(E), 0);
    const bool threshold = !std::isnan(p_.blend_threshold);
    const V3 camera{p_.camera[0], p_.camera[1], p_.camera[2]};
    // Per edge, independent: in parallel, then the blended edges counted.
    tbb::parallel_for(tbb::blocked_range<int32_t>(0, E, 16384), [&](const tbb::blocked_range<int32_t>& range) {
      for (int32_t e = range.begin(); e < range.end(); ++e) {
        const V3 a = v3(m_.positions + 3 * size_t(r.edges.vertices[2 * size_t(e)]));
        const V3 b = v3(m_.positions + 3 * size_t(r.edges.vertices[2 * size_t(e) + 1]));
        double phi = std::numeric_limits<double>::quiet_NaN();
        if (p_.has_camera) {
          const double dist = norm(camera - (a + b) * 0.5);
          const double num = p_.lambda * double(r.edge_error[e]) * norm(b - a);
          phi = num == 0 ? 0.0 : dist > 0 ? num / dist : std::numeric_limits<double>::infinity();
          r.edge_phi[e] = float(phi);
        }
        const bool interior = r.edges.edge_corner_start[e + 1] - r.edges.edge_corner_start[e] >= 2;
        // Compare in float, as reported, so the flag agrees exactly with edge_phi > threshold.
        r.edge_blended[e] = p_.blend && interior && (!threshold || r.edge_phi[e] > float(p_.blend_threshold));
      }
    });
    for (uint8_t blended : r.edge_blended) r.stats.blended_edges += blended;
  }

  // Vertex mappings (see texton_synth.hpp): each vertex takes the mapping of one incident polygon
  // (its owner): the mapping's texel at the vertex, and that polygon's frame.
  struct VertexMapping {
    float x = 0, y = 0;
    int32_t poly = -1;
  };
  // Owner: the incident polygon textured first among those whose mapping, extended over every
  // polygon around the vertex, stays inside a non-tileable sample (else clamped: smeared); when
  // none does, the first textured. Stores, for each corner of the vertex in a polygon of at most 4
  // corners, the owner's mapping over that polygon as texels in the corner's blend set
  // (kCornerSet) of `out`, which write_blend_sets then turns into UVs. Each (set, polygon) slot
  // belongs to one corner, so one vertex: vertices run in parallel.
  void store_vertex_mappings(const CornerMapsView& out) const {
    tbb::parallel_for(tbb::blocked_range<int32_t>(0, m_.num_vertices, 1024), [&](const tbb::blocked_range<int32_t>& r) {
      throw_if_cancelled(p_.cancel);
      std::vector<std::pair<int32_t, int32_t>> candidates;  // (when its polygon was textured, corner)
      for (int32_t v = r.begin(); v < r.end(); ++v) {
        candidates.clear();
        for (int32_t k = m_.vertex_corner_start[v]; k < m_.vertex_corner_start[v + 1]; ++k)
          candidates.emplace_back(placed_at_[m_.corner_poly[m_.vertex_corners[k]]], m_.vertex_corners[k]);
        if (candidates.empty()) continue;
        // Ties (a polygon through v twice) keep ascending corners, as the corners are listed.
        std::sort(candidates.begin(), candidates.end());
        auto mapping = [&](int32_t c) { return VertexMapping{texel_[2 * size_t(c)], texel_[2 * size_t(c) + 1], m_.corner_poly[c]}; };
        // Writes vm over every polygon around v; false (and stops) at the first that leaves the
        // sample when `check`. The slots of a rejected candidate are rewritten by the next one.
        auto store = [&](const VertexMapping& vm, bool check) {
          for (int32_t k = m_.vertex_corner_start[v]; k < m_.vertex_corner_start[v + 1]; ++k) {
            const int32_t corner = m_.vertex_corners[k], poly = m_.corner_poly[corner];
            const int32_t n = m_.poly_sizes[poly], first = m_.poly_starts[poly];
            if (n > 4) continue;
            float xy[8];
            vertex_set_values(vm, poly, corner - first, xy);
            const int32_t set = kCornerSet[n - 3][corner - first];
            for (int32_t i = 0; i < n; ++i) {
              float* to = out.set_uv(set, size_t(first + i));
              to[0] = xy[2 * i], to[1] = xy[2 * i + 1];
            }
            if (check)
              for (int32_t i = 0; i < n; ++i)
                if (!(xy[2 * i] >= 0.f && xy[2 * i] <= W_ && xy[2 * i + 1] >= 0.f && xy[2 * i + 1] <= H_)) return false;
          }
          return true;
        };
        bool stored = false;
        if (!tileable_)
          for (const auto& candidate : candidates)
            if ((stored = store(mapping(candidate.second), true))) break;
        if (!stored) store(mapping(candidates[0].second), false);
      }
    });
  }

  // Texels of vertex mapping vm over polygon `poly` (at most 4 corners), whose corner i is the vertex:
  // the owner polygon's frame (see texton_synth.hpp).
  void vertex_set_values(const VertexMapping& vm, int32_t poly, int32_t i, float* xy) const {
    vertex_mapping_offsets(m_, poly, i, frame_[vm.poly], xy);
    for (int32_t k = 0; k < m_.poly_sizes[poly]; ++k) xy[2 * k] += vm.x, xy[2 * k + 1] += vm.y;
  }

  // Pass 3 (parallel, each polygon writes its own corners): blend sets, see texton_synth.hpp.
  void write_blend_sets(TextonSynthResult& r, const CornerMapsView& out) const {
    const MeshEdges& edges = r.edges;
    const int32_t S = out.num_blend_sets;
    if (S > 1) store_vertex_mappings(out);
    std::atomic<int64_t> clipped_sets{0};
    tbb::parallel_for(tbb::blocked_range<int32_t>(0, m_.num_polys, 2048), [&](const tbb::blocked_range<int32_t>& range) {
      throw_if_cancelled(p_.cancel);
      for (int32_t poly = range.begin(); poly < range.end(); ++poly) {
        const int32_t first = m_.poly_starts[poly], n = m_.poly_sizes[poly];
        bool blended = false;
        for (int32_t i = 0; i < n && S > 1; ++i) {
          const int32_t e = edges.corner_edge[first + i];
          blended = blended || (e >= 0 && r.edge_blended[e]);
        }
        blended = blended && n <= 4;  // else its own patch only (n-gons: no edge zones)
        // Sets a blended polygon's corners use hold vertex mappings (below); the others the base, weight 0.
        const int32_t* used = blended ? kCornerSet[n - 3] : nullptr;
        for (int32_t i = 0; i < n; ++i) {
          const float* base = out.base_uv + 2 * size_t(first + i);
          for (int32_t set = 0; set < S; ++set) {
            if (used && std::find(used, used + n, set) != used + n) continue;
            float* uv = out.set_uv(set, size_t(first + i));
            uv[0] = base[0], uv[1] = base[1];
          }
          if (out.packed_pairs && S % 2 == 1) out.set_uv(S, size_t(first + i))[0] = out.set_uv(S, size_t(first + i))[1] = 0.f;
          std::fill_n(out.blend_weights + size_t(first + i) * S, S, S == 1 ? 1.f : 0.f);
        }
        if (!blended) continue;
        bool clipped = false;
        for (int32_t i = 0; i < n; ++i) {
          const int32_t set = kCornerSet[n - 3][i];
          for (int32_t k = 0; k < n; ++k) {  // the texels store_vertex_mappings left in the set, to UVs
            float* uv = out.set_uv(set, size_t(first + k));
            const float x = uv[0], y = uv[1];
            clipped = clipped || (!tileable_ && !(x >= 0.f && x <= W_ && y >= 0.f && y <= H_));
            texel_to_uv(x, y, uv);
          }
          out.blend_weights[(first + i) * size_t(S) + set] = 1.f;
        }
        if (clipped) clipped_sets.fetch_add(1, std::memory_order_relaxed);
      }
    });
    r.stats.clipped_blend_sets = clipped_sets.load();
  }

  const Preprocessed& pre_;
  const Mesh& m_;
  const float* orientation_;
  const SampleImage& sample_;
  const TextonSynthParams& p_;
  const float W_, H_;
  const bool tileable_;
  UninitializedVector<float> offset_;   // per corner: texel offset from its polygon's corner 0 (face frame)
  UninitializedVector<float> box_;      // per polygon: min x, min y, max x, max y of the offsets
  UninitializedVector<float> texel_;    // per corner: texel coordinate once its polygon is textured
  UninitializedVector<uint8_t> textured_;
  UninitializedVector<FaceFrame> frame_;   // per polygon: its texture frame (face_frame.hpp)
  UninitializedVector<int32_t> placed_at_; // per polygon: when it was textured (growth order)
  std::vector<int32_t> component_faces_, component_start_;  // see collect_components
  UninitializedVector<int32_t> twin_;  // see find_twins
  double coherence_bound_ = 0;     // coherence_threshold × mean texton distance (0: off)
};

}  // namespace

TextonSynthResult synthesize_texton(const Preprocessed& pre, const Mesh& mesh, const float* orientation,
                                    const SampleImage& sample, const TextonSynthParams& params,
                                    const CornerMapsView& out) {
  const auto start = std::chrono::steady_clock::now();
  validate_textons(pre);
  validate_sample(pre, sample);
  validate_params(mesh, orientation, params);
  const int32_t S = texton_blend_sets(params.blend);
  check_corner_maps_view(out, mesh.num_corners, S, "synthesize_texton");
  TextonSynthResult r = TextonSynthesizer(pre, mesh, orientation, sample, params).run(out);
  r.stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

TextonSynthResult synthesize_texton(const Preprocessed& pre, const Mesh& mesh, const float* orientation,
                                    const SampleImage& sample, const TextonSynthParams& params) {
  CornerMaps maps = allocate_corner_maps(mesh.num_corners, texton_blend_sets(params.blend));
  TextonSynthResult r = synthesize_texton(pre, mesh, orientation, sample, params, view_of(maps));
  r.maps = std::move(maps);
  return r;
}

}  // namespace texsynth
