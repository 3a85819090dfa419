// SPDX-License-Identifier: GPL-3.0-or-later
// Jump-map synthesis on meshes (Zelinka & Garland §4.2–4.4). See jumpmap_synth.hpp for conventions.
#include "texsynth/synth/jumpmap_synth.hpp"
#include "texsynth/synth/face_frame.hpp"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <exception>
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

namespace texsynth {
namespace {

constexpr double kMaxOffset = 1e9;
constexpr int32_t kMaxSetCorners = 4;  // polygons with more corners share sets between corner runs

struct Box {  // texel-space offsets reachable from a vertex's address through its polygons
  float min_x = 0, min_y = 0, max_x = 0, max_y = 0;
};

struct Touched {  // output buffers measure_faces wrote (their pages are already faulted in)
  bool blend_uv = false, blend_weights = false;
};

void validate_preprocessed(const Preprocessed& pre) {
  if (pre.width <= 0 || pre.height <= 0)
    throw std::invalid_argument("preprocessed sample has no pixels (" + std::to_string(pre.width) + "x" +
                                std::to_string(pre.height) + ")");
  const int64_t pixels = int64_t(pre.width) * pre.height;
  const int k = pre.jump_map.k;
  if (pixels > std::numeric_limits<int32_t>::max() || k < 0 || k > 1024)
    throw std::invalid_argument("preprocessed sample: size or jump count out of range");
  if (int64_t(pre.jump_map.targets.size()) != pixels * k || int64_t(pre.jump_map.weights.size()) != pixels * k)
    throw std::invalid_argument("preprocessed jump map has " + std::to_string(pre.jump_map.targets.size()) +
                                " entries, expected width*height*k = " + std::to_string(pixels * k));
  for (size_t i = 0; i < pre.jump_map.targets.size(); ++i) {
    int32_t t = pre.jump_map.targets[i];
    float w = pre.jump_map.weights[i];
    if (t < -1 || t >= pixels || !std::isfinite(w) || w < 0.f)
      throw std::invalid_argument("preprocessed jump map entry " + std::to_string(i) + " is invalid (target " +
                                  std::to_string(t) + ", weight " + std::to_string(w) + ")");
  }
}

void validate_params(const Mesh& m, const float* orientation, const JumpSynthParams& p) {
  if (!std::isfinite(p.scale) || p.scale <= 0 || p.scale > 1e30)
    throw std::invalid_argument("scale (texels per object unit) must be finite, > 0 and <= 1e30");
  if (!(p.jump_rate > 0 && p.jump_rate <= 1e9)) throw std::invalid_argument("jump_rate must be in (0, 1e9]");
  if (p.max_rejection_draws < 0 || p.max_rejection_draws > 1000)
    throw std::invalid_argument("max_rejection_draws must be in [0, 1000]");
  if (!std::isfinite(p.border_ramp)) throw std::invalid_argument("border_ramp must be finite");  // 0 = no ramp
  validate_vertex_inputs(m, orientation, p.scale_multiplier);
}

class Synthesizer {
 public:
  Synthesizer(const Preprocessed& pre, const Mesh& m, const float* orientation, const JumpSynthParams& p)
      : pre_(pre), m_(m), p_(p), W_(float(pre.width)), H_(float(pre.height)), tileable_(pre.params.tileable),
        blend_(p.blend) {
    border_ramp_ = p.border_ramp >= 0 ? float(p.border_ramp) : std::max(1.f, 0.05f * std::min(W_, H_));
    const auto start = std::chrono::steady_clock::now();
    build_frames(orientation);
    frames_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }

  JumpSynthResult run(const CornerMapsView& out) {
    JumpSynthResult r;
    throw_if_cancelled(p_.cancel);
    using Clock = std::chrono::steady_clock;
    auto since = [](Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); };
    Clock::time_point t = Clock::now();
    const Touched touched = measure_faces(r.stats, out);
    throw_if_cancelled(p_.cancel);
    check_oversized_faces(r.stats.oversized_faces, r.stats.max_oversize_ratio, m_.num_polys, pre_.width, pre_.height,
                          p_.scale, p_.allow_oversized);
    r.stats.seconds_faces = since(t) + frames_seconds_;
    t = Clock::now();
    order_and_walk(r.stats, out, touched);
    r.stats.seconds_walk = since(t);
    throw_if_cancelled(p_.cancel);
    t = Clock::now();
    write_corners(out);
    r.stats.seconds_corners = since(t);
    throw_if_cancelled(p_.cancel);
    r.vertex_address.resize(size_t(m_.num_vertices) * 2);
    auto copy_addresses = [&](int32_t begin, int32_t end) {
      for (int32_t v = begin; v < end; ++v) {
        r.vertex_address[2 * size_t(v)] = state_[v].address[0];
        r.vertex_address[2 * size_t(v) + 1] = state_[v].address[1];
      }
    };
    if (p_.baseline_passes) {
      copy_addresses(0, m_.num_vertices);
    } else {  // in parallel: a serial pass (and its fresh pages) after the parallel corner pass
      tbb::parallel_for(tbb::blocked_range<int32_t>(0, m_.num_vertices, 16384),
                        [&](const tbb::blocked_range<int32_t>& range) { copy_addresses(range.begin(), range.end()); });
    }
    r.stats.faces = m_.num_polys;
    r.stats.vertices = m_.num_vertices;
    r.stats.corners = m_.num_corners;
    r.stats.components = m_.num_components;
    return r;
  }

 private:
  float multiplier(int32_t v) const { return p_.scale_multiplier ? p_.scale_multiplier[v] : 1.f; }
  V3 pos(int32_t v) const { return v3(m_.positions + 3 * size_t(v)); }

  void build_frames(const float* orientation) {
    state_.resize(size_t(m_.num_vertices));
    tbb::parallel_for(tbb::blocked_range<int32_t>(0, m_.num_vertices, 8192), [&](const tbb::blocked_range<int32_t>& r) {
      for (int32_t v = r.begin(); v < r.end(); ++v) {
        V3 n = v3(&m_.normals[3 * size_t(v)]);
        V3 u = project_to_plane(v3(orientation + 3 * size_t(v)), n);
        const double len = norm(u);
        // Near a singularity (orientation ~ normal) the projection is rounding noise, partly along n:
        // then any tangent direction; otherwise project once more so up is exactly tangent.
        u = len > 1e-6 && std::isfinite(len) ? normalized_or(project_to_plane(u * (1.0 / len), n), any_perpendicular(n))
                                             : any_perpendicular(n);
        VertexState& st = state_[v];
        store(st.up, u);
        store(st.right, cross(u, n));
        st.address[0] = st.address[1] = std::numeric_limits<float>::quiet_NaN();
      }
    });
  }

  // Texel offsets of a polygon's corners relative to its corner 0 (shared with the texton synthesizer).
  void face_offsets(int32_t poly, float* xy) const {
    face_texel_offsets(m_, poly, [this](int32_t v) { return v3(state_[v].up); }, p_.scale, p_.scale_multiplier, xy);
  }

  // Vertex v's frame as the blend set grown from v uses it (vertex_mapping_offsets): its tangent
  // frame, scale × v's multiplier.
  FaceFrame vertex_frame(int32_t v) const {
    FaceFrame f;
    f.right = v3(state_[v].right);
    f.up = v3(state_[v].up);
    f.scale = p_.scale * double(multiplier(v));
    return f;
  }

  // Texel-space bounds of polygon `poly`'s corner offsets, including corner 0's (0, 0).
  Box face_box(int32_t poly) const {
    const float* xy = &corner_offset_[2 * size_t(m_.poly_starts[poly])];
    Box b;
    for (int32_t i = 0; i < m_.poly_sizes[poly]; ++i) {
      b.min_x = std::min(b.min_x, xy[2 * i]), b.max_x = std::max(b.max_x, xy[2 * i]);
      b.min_y = std::min(b.min_y, xy[2 * i + 1]), b.max_y = std::max(b.max_y, xy[2 * i + 1]);
    }
    return b;
  }

  // The reach box of corner `c` of polygon `poly` (corner i, face box b): the base mapping's
  // corners and those of the blend set grown from c, relative to c (see measure_faces).
  // With `stash`, the blend set grown from c (set i, see write_corners) is stored there as offsets.
  template <class Include>
  void corner_reach(int32_t poly, int32_t c, const Box& b, Include&& include, const CornerMapsView* stash = nullptr) const {
    const double x = corner_offset_[2 * size_t(c)], y = corner_offset_[2 * size_t(c) + 1];
    include(float(b.min_x - x), float(b.min_y - y));  // the base mapping (polygon frame)
    include(float(b.max_x - x), float(b.max_y - y));
    if (blend_) {  // the blend set grown from c's vertex (see vertex_mapping_offsets)
      float offsets[2 * kMaxSetCorners];
      const int32_t n = m_.poly_sizes[poly];
      if (n <= kMaxSetCorners) {
        const int32_t i = c - m_.poly_starts[poly];
        vertex_mapping_offsets(m_, poly, i, vertex_frame(m_.corner_verts[c]), offsets);
        for (int32_t k = 0; k < n; ++k) include(offsets[2 * k], offsets[2 * k + 1]);
        if (stash)
          for (int32_t k = 0; k < n; ++k) {
            float* to = stash->set_uv(i, size_t(m_.poly_starts[poly]) + k);
            to[0] = offsets[2 * k], to[1] = offsets[2 * k + 1];
          }
      } else {  // n-gon sets follow the polygon frame (see write_corners)
        include(float(b.min_x - x), float(b.min_y - y));
        include(float(b.max_x - x), float(b.max_y - y));
      }
    }
  }

  // Pass 1: in-face corner offsets (parallel, per polygon), then per-vertex reach boxes (validity,
  // §4.2.4) and oversized-face statistics (exact max and count). A vertex's box is the min/max
  // over its corners' boxes, started at 0: exact, so the same floats in any order or thread count.
  // The corner boxes need the polygon's corners, positions and frames: on a mesh whose vertex and
  // polygon orders disagree, gathering them per vertex misses the cache on every corner. So each
  // polygon pass writes its corners' boxes (16 bytes per corner) and the vertex pass only reads
  // those. They go into the blend-weight output when it has room (written later by write_corners
  // anyway: no fresh pages for a temporary). The vertex-mapping offsets the boxes are made of are
  // the blend sets' values less the vertex's address: they are stored in the blend-set output, and
  // write_corners adds the addresses instead of computing them again (see stashed_sets_).
  Touched measure_faces(SynthStats& st, const CornerMapsView& out) {
    corner_offset_.resize(size_t(m_.num_corners) * 2);
    const size_t L = size_t(m_.num_corners), S = size_t(out.num_blend_sets);
    UninitializedVector<float> own_boxes;
    float* corner_box = nullptr;  // 4 floats per corner: min x, min y, max x, max y
    Touched touched;
    if (!p_.baseline_passes) {
      if (S >= 4) {
        corner_box = out.blend_weights;
        touched.blend_weights = true;
      } else {
        own_boxes.resize(4 * L);
        corner_box = own_boxes.data();
      }
      stashed_sets_ = touched.blend_uv = blend_;
    }
    std::atomic<int32_t> first_huge_face{std::numeric_limits<int32_t>::max()};
    const double w = pre_.width, h = pre_.height;
    struct Oversize {
      double max_ratio = 0;
      int64_t count = 0;
    };
    tbb::combinable<Oversize> oversize;
    tbb::parallel_for(tbb::blocked_range<int32_t>(0, m_.num_polys, 4096), [&](const tbb::blocked_range<int32_t>& r) {
      throw_if_cancelled(p_.cancel);
      Oversize& local = oversize.local();
      for (int32_t poly = r.begin(); poly < r.end(); ++poly) {
        const float* xy = &corner_offset_[2 * size_t(m_.poly_starts[poly])];
        face_offsets(poly, &corner_offset_[2 * size_t(m_.poly_starts[poly])]);
        for (int32_t i = 0; i < m_.poly_sizes[poly]; ++i)
          // Beyond ~1e9 texels float addresses are meaningless; refuse even with allow_oversized.
          if (!(std::fabs(xy[2 * i]) <= kMaxOffset && std::fabs(xy[2 * i + 1]) <= kMaxOffset)) {
            int32_t seen = first_huge_face.load();
            while (poly < seen && !first_huge_face.compare_exchange_weak(seen, poly)) {
            }
          }
        const Box b = face_box(poly);
        const double ratio = std::max((double(b.max_x) - b.min_x) / w, (double(b.max_y) - b.min_y) / h);
        local.max_ratio = std::max(local.max_ratio, ratio);
        if (ratio > 1.0) ++local.count;
        if (corner_box)
          for (int32_t c = m_.poly_starts[poly]; c < m_.poly_starts[poly] + m_.poly_sizes[poly]; ++c) {
            Box reach;
            corner_reach(poly, c, b, [&reach](float x, float y) {
              reach.min_x = std::min(reach.min_x, x), reach.max_x = std::max(reach.max_x, x);
              reach.min_y = std::min(reach.min_y, y), reach.max_y = std::max(reach.max_y, y);
            }, stashed_sets_ ? &out : nullptr);
            float* to = corner_box + 4 * size_t(c);
            to[0] = reach.min_x, to[1] = reach.min_y, to[2] = reach.max_x, to[3] = reach.max_y;
          }
      }
    });
    if (first_huge_face.load() < m_.num_polys)  // the lowest such face, as a serial loop would report
      throw std::invalid_argument("scale " + std::to_string(p_.scale) + " makes face " +
                                  std::to_string(first_huge_face.load()) + " span more than 1e9 texels");
    oversize.combine_each([&](const Oversize& o) {
      st.max_oversize_ratio = std::max(st.max_oversize_ratio, o.max_ratio);
      st.oversized_faces += o.count;
    });
    reach_.resize(size_t(m_.num_vertices));
    tbb::parallel_for(tbb::blocked_range<int32_t>(0, m_.num_vertices, 4096), [&](const tbb::blocked_range<int32_t>& r) {
      throw_if_cancelled(p_.cancel);
      for (int32_t v = r.begin(); v < r.end(); ++v) {
        Box reach;
        auto include = [&reach](float x, float y) {
          reach.min_x = std::min(reach.min_x, x), reach.max_x = std::max(reach.max_x, x);
          reach.min_y = std::min(reach.min_y, y), reach.max_y = std::max(reach.max_y, y);
        };
        for (int32_t k = m_.vertex_corner_start[v]; k < m_.vertex_corner_start[v + 1]; ++k) {
          const int32_t c = m_.vertex_corners[k];
          if (corner_box) {
            const float* from = corner_box + 4 * size_t(c);
            include(from[0], from[1]), include(from[2], from[3]);
          } else {  // baseline: the polygon's data gathered per corner
            const int32_t poly = m_.corner_poly[c];
            corner_reach(poly, c, face_box(poly), include);
          }
        }
        reach_[v] = reach;
      }
    });
    return touched;
  }

  // Distance (texels) from the reach box placed at (x, y) to the nearest sample border; < 0 = invalid.
  float border_margin(float x, float y, const Box& b) const {
    if (tileable_) return std::numeric_limits<float>::infinity();
    return std::min(std::min(x + b.min_x, W_ - (x + b.max_x)), std::min(y + b.min_y, H_ - (y + b.max_y)));
  }

  // Texel offset for walking edge a -> b (§4.2.2): the edge projected on the averaged endpoint frames.
  void edge_offset(int32_t a, int32_t b, float& dx, float& dy) const {
    const float* pa = m_.positions + 3 * size_t(a);
    const float* pb = m_.positions + 3 * size_t(b);
    const float e[3] = {pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]};
    const float* ua = state_[a].up;
    const float* ub = state_[b].up;
    const float* ra = state_[a].right;
    const float* rb = state_[b].right;
    float U[3] = {ua[0] + ub[0], ua[1] + ub[1], ua[2] + ub[2]};
    float R[3] = {ra[0] + rb[0], ra[1] + rb[1], ra[2] + rb[2]};
    float lu = U[0] * U[0] + U[1] * U[1] + U[2] * U[2];
    float lr = R[0] * R[0] + R[1] * R[1] + R[2] * R[2];
    if (!(lu > 1e-6f && lr > 1e-6f)) {  // opposite frames (next to a singularity): use a's frame
      std::copy(ua, ua + 3, U), std::copy(ra, ra + 3, R);
      lu = lr = 1.f;
    }
    const float s = float(p_.scale) * 0.5f * (multiplier(a) + multiplier(b));
    dx = (e[0] * R[0] + e[1] * R[1] + e[2] * R[2]) * (s / std::sqrt(lr));
    dy = -(e[0] * U[0] + e[1] * U[1] + e[2] * U[2]) * (s / std::sqrt(lu));
  }

  // A uniformly random address whose reach box fits the sample (centred when it cannot fit).
  void random_address(Rng& rng, const Box& b, float& x, float& y) const {
    auto pick = [&](float lo, float hi, float size) {
      float min_pos = -lo, max_pos = size - hi;
      if (tileable_) return float(rng.uniform() * size);
      if (max_pos < min_pos) return 0.5f * (min_pos + max_pos);
      return std::min(max_pos, min_pos + float(rng.uniform()) * (max_pos - min_pos));
    };
    x = pick(b.min_x, b.max_x, W_);
    y = pick(b.min_y, b.max_y, H_);
  }

  struct Candidate {
    float x, y, weight;
    bool jump;
  };

  // One synthesized neighbour's contribution to a vertex's selection table (§4.2.5): its
  // continuation and the jump lists of the 4 texels around its address (§4.2.3).
  struct Source {
    float cx, cy, continuation;  // continuation address and weight (0 when invalid)
    int32_t texel[4];            // pixel index, -1 when outside a non-tileable sample
    float bilinear[4];           // bilinear weight of each texel
    float texel_weight[4];       // bilinear × the texel's summed jump weights
  };

  // The order (§4.1) and the walk over it are both serial: with a second thread the order is built
  // there while the walk follows it, a few entries behind. Same order and draws either way. The
  // order is much faster than the walk, so that thread then pre-faults the output pages not yet
  // touched (those measure_faces did not write), off the critical path.
  void order_and_walk(SynthStats& st, const CornerMapsView& out, const Touched& touched) {
    UninitializedVector<int32_t> order(size_t(m_.num_vertices));
    UninitializedVector<uint32_t> ordered_neighbours(size_t(m_.num_vertices));
    std::atomic<int32_t> ready{0};
    std::atomic<bool> order_done{false};
    std::exception_ptr order_error;
    auto build_order = [&] {
      try {
        stream_region_growing_order(m_, p_.seed, order.data(), ordered_neighbours.data(), ready, p_.cancel);
      } catch (...) {
        order_error = std::current_exception();
      }
      order_done.store(true, std::memory_order_release);
    };
    auto order_then_prefault = [&] {
      build_order();
      if (p_.baseline_passes || order_error) return;
      const size_t L = size_t(out.num_corners), S = size_t(out.num_blend_sets);
      auto cancelled = [this] { return p_.cancel && p_.cancel->load(std::memory_order_relaxed); };
      prefault_pages(out.base_uv, 2 * L, cancelled);
      if (!touched.blend_weights) prefault_pages(out.blend_weights, S * L, cancelled);
      if (!touched.blend_uv) prefault_pages(out.blend_uv, out.packed_pairs ? (S + 1) / 2 * L * 4 : S * L * 2, cancelled);
    };
    std::thread producer;
    if (usable_threads() > 1) {
      try {
        producer = std::thread(order_then_prefault);
      } catch (const std::system_error&) {  // no thread to be had: build the order here first
      }
    }
    if (producer.joinable()) {
      struct Join {
        std::thread& thread;
        ~Join() { thread.join(); }  // also when the walk throws (Cancelled: the producer stops too)
      } join{producer};
      walk(order.data(), ordered_neighbours.data(), ready, order_done, st);
    } else {
      build_order();
      walk(order.data(), ordered_neighbours.data(), ready, order_done, st);
    }
    if (order_error) std::rethrow_exception(order_error);
    throw_if_cancelled(p_.cancel);
  }

  // How many order entries are final once entry `step` is needed: waits until it is ready or the
  // order is complete (then the final count, == step at the end).
  static int32_t wait_for_order(int32_t step, const std::atomic<int32_t>& ready, const std::atomic<bool>& done) {
    while (true) {
      const bool finished = done.load(std::memory_order_acquire);  // before `ready`: then it is final
      const int32_t count = ready.load(std::memory_order_acquire);
      if (count > step || finished) return count;
      std::this_thread::yield();
    }
  }

  // Pass 2: the walk (§4.2.3–4.2.5). Sequential by nature; one RNG stream, so deterministic.
  // Drawing from the filtered table is done by rejection: draw among continuations (validated
  // exactly) and all jump entries, redraw when a drawn jump is invalid. That yields exactly the
  // filtered distribution without validating every entry; after max_rejection_draws the exact
  // filtered table is built instead (e.g. next to the border, where most jumps are invalid).
  // ordered_neighbours[step]: which of the vertex's first 32 neighbours were walked before it (see
  // stream_region_growing_order); the others are not read, since their records are far away in
  // memory and unsynthesized anyway.
  void walk(const int32_t* order, const uint32_t* ordered_neighbours, const std::atomic<int32_t>& ready,
            const std::atomic<bool>& order_done, SynthStats& st) {
    const int max_draws = p_.max_rejection_draws;
    const int32_t k = pre_.jump_map.k;
    const int32_t width = pre_.width, height = pre_.height;
    const int32_t* targets = pre_.jump_map.targets.data();
    const float* weights = pre_.jump_map.weights.data();
    // Summed jump weight per pixel: the draw only looks at entries of the texel it lands in.
    std::vector<float> pixel_weight(size_t(width) * height, 0.f);
    for (size_t p = 0; p < pixel_weight.size(); ++p)
      for (int32_t e = 0; e < k; ++e)
        if (targets[p * k + e] >= 0) pixel_weight[p] += weights[p * k + e];
    // Destination of jump entry e of `texel` taken from src: target - source pixel, plus src's address.
    auto destination = [&](const Source& src, int32_t texel, int32_t e, float& x, float& y) {
      const int32_t t = targets[size_t(texel) * k + e];
      x = src.cx + float(t % width - texel % width);
      y = src.cy + float(t / width - texel / width);
    };
    const float rate = float(p_.jump_rate);
    std::vector<Source> sources;
    std::vector<Candidate> table;
    std::vector<char> fell_back(m_.num_vertices, 0);
    Rng rng(p_.seed, 0x6a756d70);  // "jump"
    int32_t available = 0;
    for (int32_t step = 0;; ++step) {
      if (step == available && (available = wait_for_order(step, ready, order_done)) == step) break;
      const int32_t v = order[step];
      if (((step + 1) & 4095) == 0) throw_if_cancelled(p_.cancel);
      const Box& box = reach_[v];
      if (sources.size() < size_t(m_.degree(v))) sources.resize(m_.degree(v));
      size_t count = 0;
      double total = 0;
      const uint32_t before = ordered_neighbours[step];
      for (int32_t kk = m_.neighbour_start[v]; kk < m_.neighbour_start[v + 1]; ++kk) {
        const int32_t slot = kk - m_.neighbour_start[v];
        if (slot < 32 && !(before >> slot & 1u)) continue;
        const int32_t j = m_.neighbours[kk];
        if (!state_[j].synthesized()) continue;
        Source& src = sources[count++];
        float dx, dy;
        edge_offset(j, v, dx, dy);
        const float ax = state_[j].address[0], ay = state_[j].address[1];
        // Continuation ("do not jump"): weight jump_rate / |offset|, ramped down near the border.
        src.cx = ax + dx, src.cy = ay + dy;
        const float margin = border_margin(src.cx, src.cy, box);
        const float len = std::max(std::sqrt(dx * dx + dy * dy), 1e-3f);
        const float ramp = tileable_ || border_ramp_ <= 0.f ? 1.f : std::min(1.f, margin / border_ramp_);
        src.continuation = margin >= 0.f ? rate / len * ramp : 0.f;
        total += src.continuation;
        // Bilinear floating-point jump look-up at the neighbour's address.
        const float fx = ax - 0.5f, fy = ay - 0.5f;
        const float x0 = std::floor(fx), y0 = std::floor(fy);
        const float tx = fx - x0, ty = fy - y0;
        for (int corner = 0; corner < 4; ++corner) {
          int32_t qx = int32_t(x0) + (corner & 1), qy = int32_t(y0) + (corner >> 1);
          src.bilinear[corner] = ((corner & 1) ? tx : 1.f - tx) * ((corner >> 1) ? ty : 1.f - ty);
          if (tileable_) {
            qx = ((qx % width) + width) % width, qy = ((qy % height) + height) % height;
          } else if (qx < 0 || qy < 0 || qx >= width || qy >= height || k == 0) {
            src.texel[corner] = -1, src.texel_weight[corner] = 0.f;
            continue;
          }
          src.texel[corner] = qy * width + qx;
          src.texel_weight[corner] = src.bilinear[corner] * pixel_weight[src.texel[corner]];
          total += src.texel_weight[corner];
        }
      }
      float x = 0, y = 0;
      bool chosen = false, jumped = false;
      for (int draw = 0; draw < max_draws && total > 0 && !chosen; ++draw) {
        double r = rng.uniform() * total;
        bool landed = false;  // on a continuation or a jump entry (rounding may leave r past the end)
        for (size_t i = 0; i < count && !landed; ++i) {
          const Source& src = sources[i];
          if (r < src.continuation) {
            x = src.cx, y = src.cy, chosen = landed = true;
            break;
          }
          r -= src.continuation;
          for (int corner = 0; corner < 4; ++corner) {
            if (r >= src.texel_weight[corner]) {
              r -= src.texel_weight[corner];
              continue;
            }
            const size_t base = size_t(src.texel[corner]) * k;
            for (int32_t e = 0; e < k; ++e) {
              const bool used = targets[base + e] >= 0;
              const double w = used ? double(weights[base + e]) * src.bilinear[corner] : 0.0;
              if (r < w || e + 1 == k) {
                chosen = used && w > 0;
                if (chosen) destination(src, src.texel[corner], e, x, y);
                chosen = chosen && border_margin(x, y, box) >= 0.f;  // else: rejected, redraw
                jumped = chosen;
                landed = true;
                break;
              }
              r -= w;
            }
            break;
          }
        }
      }
      if (!chosen && total > 0) {  // exact filtered table
        table.clear();
        double exact_total = 0;
        auto add = [&](float cx, float cy, float w, bool jump) {
          if (w > 0.f && border_margin(cx, cy, box) >= 0.f) table.push_back({cx, cy, w, jump}), exact_total += w;
        };
        for (size_t i = 0; i < count; ++i) {
          const Source& src = sources[i];
          add(src.cx, src.cy, src.continuation, false);
          for (int corner = 0; corner < 4; ++corner) {
            if (src.texel_weight[corner] <= 0.f) continue;
            for (int32_t e = 0; e < k; ++e) {
              if (targets[size_t(src.texel[corner]) * k + e] < 0) continue;
              float jx, jy;
              destination(src, src.texel[corner], e, jx, jy);
              add(jx, jy, weights[size_t(src.texel[corner]) * k + e] * src.bilinear[corner], true);
            }
          }
        }
        if (!table.empty()) {
          double r = rng.uniform() * exact_total;
          size_t pick = 0;
          while (pick + 1 < table.size() && r >= table[pick].weight) r -= table[pick++].weight;
          x = table[pick].x, y = table[pick].y, jumped = table[pick].jump, chosen = true;
        }
      }
      if (!chosen) {
        random_address(rng, box, x, y);
        if (count > 0) ++st.fallback_vertices, fell_back[v] = 1;
      }
      if (jumped) ++st.jumps;
      if (tileable_) {
        x -= W_ * std::floor(x / W_), y -= H_ * std::floor(y / H_);
        if (x >= W_) x = 0.f;  // a tiny negative x rounds to exactly W_
        if (y >= H_) y = 0.f;
      }
      state_[v].address[0] = x, state_[v].address[1] = y;
    }
    if (st.fallback_vertices == 0) return;
    auto count_faces = [&](int32_t begin, int32_t end) {
      int64_t faces = 0;
      for (int32_t poly = begin; poly < end; ++poly)
        for (int32_t i = 0; i < m_.poly_sizes[poly]; ++i)
          if (fell_back[m_.corner_verts[m_.poly_starts[poly] + i]]) {
            ++faces;
            break;
          }
      return faces;
    };
    if (p_.baseline_passes) {
      st.fallback_faces = count_faces(0, m_.num_polys);
    } else {  // an exact count, so the same in parallel
      st.fallback_faces = tbb::parallel_reduce(
          tbb::blocked_range<int32_t>(0, m_.num_polys, 16384), int64_t(0),
          [&](const tbb::blocked_range<int32_t>& range, int64_t faces) {
            return faces + count_faces(range.begin(), range.end());
          },
          [](int64_t a, int64_t b) { return a + b; });
    }
  }

  // Pass 3: consistent per-polygon coordinates and blend sets (§4.3–4.4). Each polygon writes only
  // its own corners, so this is order-independent and runs in parallel.
  void write_corners(const CornerMapsView& out) const {
    const int32_t S = out.num_blend_sets;
    const uint64_t poly_seed = splitmix64(p_.seed ^ 0x62617365ull);  // "base"
    const float inv_w = 1.f / W_, inv_h = 1.f / H_;
    tbb::parallel_for(tbb::blocked_range<int32_t>(0, m_.num_polys, 2048), [&](const tbb::blocked_range<int32_t>& range) {
      throw_if_cancelled(p_.cancel);
      for (int32_t poly = range.begin(); poly < range.end(); ++poly) {
        const int32_t n = m_.poly_sizes[poly];
        const size_t first = size_t(m_.poly_starts[poly]);
        const float* xy = &corner_offset_[2 * first];
        // Writes corner i of the polygon in set `set` (-1: the base mapping).
        auto put = [&](int32_t set, int32_t i, float x, float y) {
          if (!tileable_) x = std::clamp(x, 0.f, W_), y = std::clamp(y, 0.f, H_);
          float* uv = set < 0 ? out.base_uv + 2 * (first + i) : out.set_uv(set, first + i);
          uv[0] = x * inv_w;
          uv[1] = 1.f - y * inv_h;
        };
        // The polygon's own mapping grown from corner `from` (polygon frame: an exact similarity).
        auto grow = [&](int32_t from, int32_t set) {
          const int32_t v = m_.corner_verts[first + from];
          const float ax = state_[v].address[0] - xy[2 * from], ay = state_[v].address[1] - xy[2 * from + 1];
          for (int32_t i = 0; i < n; ++i) put(set, i, ax + xy[2 * i], ay + xy[2 * i + 1]);
        };
        // The mapping of corner `from`'s vertex, continuous across the polygon's edges (vertex_mapping_offsets).
        auto grow_vertex = [&](int32_t from, int32_t set) {
          if (n > kMaxSetCorners) return grow(from, set);
          float offsets[2 * kMaxSetCorners];
          const int32_t v = m_.corner_verts[first + from];
          if (stashed_sets_ && set == from) {  // stored by measure_faces (corner_reach)
            for (int32_t i = 0; i < n; ++i) {
              const float* from_stash = out.set_uv(set, first + i);
              offsets[2 * i] = from_stash[0], offsets[2 * i + 1] = from_stash[1];
            }
          } else {
            vertex_mapping_offsets(m_, poly, from, vertex_frame(v), offsets);
          }
          for (int32_t i = 0; i < n; ++i) put(set, i, state_[v].address[0] + offsets[2 * i], state_[v].address[1] + offsets[2 * i + 1]);
        };
        const int32_t base = int32_t(((splitmix64(poly_seed + uint64_t(poly)) >> 32) * uint64_t(n)) >> 32);
        grow(base, -1);
        for (int32_t set = 0; set < S; ++set) {
          if (S == 1) {
            grow(base, set);
          } else if (n <= S) {
            if (set < n) grow_vertex(set, set);
            else grow(base, set);  // weight 0 everywhere
          } else {
            grow_vertex(int32_t((int64_t(set) * n + S - 1) / S), set);
          }
        }
        if (out.packed_pairs && S % 2 == 1)  // the last pair's unused half
          for (int32_t i = 0; i < n; ++i) out.set_uv(S, first + i)[0] = out.set_uv(S, first + i)[1] = 0.f;
        for (int32_t i = 0; i < n; ++i) {
          const int32_t one = S == 1 ? 0 : n <= S ? i : int32_t(int64_t(i) * S / n);
          float* w = out.blend_weights + (first + i) * S;
          for (int32_t set = 0; set < S; ++set) w[set] = set == one ? 1.f : 0.f;
        }
      }
    });
  }

  const Preprocessed& pre_;
  const Mesh& m_;
  const JumpSynthParams& p_;
  const float W_, H_;
  const bool tileable_;
  const bool blend_;
  float border_ramp_;
  double frames_seconds_ = 0;
  // measure_faces stored the vertex-mapping offsets of every polygon of at most kMaxSetCorners
  // corners in the blend-set output (set i: grown from corner i).
  bool stashed_sets_ = false;
  // Everything the walk reads per neighbour in one 32-byte record (one cache line, not four).
  struct VertexState {
    float up[3], right[3];
    float address[2];  // texel address; NaN until synthesized
    bool synthesized() const { return address[0] == address[0]; }
  };
  UninitializedVector<VertexState> state_;     // written for every vertex by build_frames
  UninitializedVector<float> corner_offset_;  // per corner: texel offset from its polygon's corner 0 (face frame)
  UninitializedVector<Box> reach_;
};

}  // namespace

int32_t jumpmap_blend_sets(const int32_t* poly_sizes, int32_t num_polys, bool blend) {
  if (!blend) return 1;
  for (int32_t p = 0; p < num_polys; ++p)
    if (poly_sizes[p] != 3) return 4;
  return 3;
}

JumpSynthResult synthesize_jumpmap(const Preprocessed& pre, const Mesh& mesh, const float* orientation,
                                   const JumpSynthParams& params, const CornerMapsView& out) {
  const auto start = std::chrono::steady_clock::now();
  validate_preprocessed(pre);
  validate_params(mesh, orientation, params);
  const int32_t S = jumpmap_blend_sets(mesh.poly_sizes, mesh.num_polys, params.blend);
  check_corner_maps_view(out, mesh.num_corners, S, "synthesize_jumpmap");
  JumpSynthResult r = Synthesizer(pre, mesh, orientation, params).run(out);
  r.stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

JumpSynthResult synthesize_jumpmap(const Preprocessed& pre, const Mesh& mesh, const float* orientation,
                                   const JumpSynthParams& params) {
  CornerMaps maps =
      allocate_corner_maps(mesh.num_corners, jumpmap_blend_sets(mesh.poly_sizes, mesh.num_polys, params.blend));
  JumpSynthResult r = synthesize_jumpmap(pre, mesh, orientation, params, view_of(maps));
  r.maps = std::move(maps);
  return r;
}

}  // namespace texsynth
