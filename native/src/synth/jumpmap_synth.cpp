// SPDX-License-Identifier: GPL-3.0-or-later
// Jump-map synthesis on meshes (Zelinka & Garland §4.2–4.4). See jumpmap_synth.hpp for conventions.
#include "texsynth/synth/jumpmap_synth.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>

#include "texsynth/common/rng.hpp"
#include "texsynth/mesh/vec_math.hpp"

namespace texsynth {
namespace {

struct Box {  // texel-space offsets reachable from a vertex's address through its polygons
  float min_x = 0, min_y = 0, max_x = 0, max_y = 0;
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
  if (!std::isfinite(p.scale) || p.scale <= 0)
    throw std::invalid_argument("scale (texels per object unit) must be finite and > 0");
  if (!std::isfinite(p.jump_rate) || p.jump_rate <= 0) throw std::invalid_argument("jump_rate must be finite and > 0");
  if (!std::isfinite(p.border_ramp)) throw std::invalid_argument("border_ramp must be finite");
  if (m.num_vertices > 0 && !orientation) throw std::invalid_argument("orientation field is missing");
  for (int64_t i = 0; i < int64_t(m.num_vertices) * 3; ++i)
    if (!std::isfinite(orientation[i]))
      throw std::invalid_argument("orientation of vertex " + std::to_string(i / 3) + " is NaN or infinite");
  if (p.scale_multiplier)
    for (int32_t v = 0; v < m.num_vertices; ++v)
      if (!std::isfinite(p.scale_multiplier[v]) || p.scale_multiplier[v] <= 0.f)
        throw std::invalid_argument("scale_multiplier of vertex " + std::to_string(v) + " must be finite and > 0");
}

class Synthesizer {
 public:
  Synthesizer(const Preprocessed& pre, const Mesh& m, const float* orientation, const JumpSynthParams& p)
      : pre_(pre), m_(m), p_(p), W_(float(pre.width)), H_(float(pre.height)), tileable_(pre.params.tileable) {
    border_ramp_ = p.border_ramp >= 0 ? float(p.border_ramp) : std::max(1.f, 0.05f * std::min(W_, H_));
    build_frames(orientation);
  }

  JumpSynthResult run() {
    JumpSynthResult r;
    reach_.assign(m_.num_vertices, Box{});
    measure_faces(r.stats);
    if (r.stats.oversized_faces > 0 && !p_.allow_oversized) {
      std::ostringstream msg;
      msg << r.stats.oversized_faces << " of " << m_.num_polys << " faces are larger than the " << pre_.width << "x"
          << pre_.height << " sample at scale " << p_.scale << " texels/unit (worst face " << r.stats.max_oversize_ratio
          << "x the sample); lower the scale by at least that factor, subdivide those faces, or pass allow_oversized=True";
      throw std::invalid_argument(msg.str());
    }
    VertexOrder order = region_growing_order(m_, p_.seed);
    walk(order, r.stats);
    write_corners(r.maps);
    r.vertex_address = std::move(address_);
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
    up_.resize(size_t(m_.num_vertices) * 3);
    right_.resize(size_t(m_.num_vertices) * 3);
    tbb::parallel_for(tbb::blocked_range<int32_t>(0, m_.num_vertices, 8192), [&](const tbb::blocked_range<int32_t>& r) {
      for (int32_t v = r.begin(); v < r.end(); ++v) {
        V3 n = v3(&m_.normals[3 * size_t(v)]);
        V3 u = normalized_or(project_to_plane(v3(orientation + 3 * size_t(v)), n), any_perpendicular(n));
        store(&up_[3 * size_t(v)], u);
        store(&right_[3 * size_t(v)], cross(u, n));
      }
    });
  }

  // Texel offsets of a polygon's corners relative to its corner 0, in the polygon's own frame:
  // an exact similarity of the polygon's projection onto its plane.
  void face_offsets(int32_t poly, std::vector<double>& xy) const {
    const int32_t* cv = m_.corner_verts + m_.poly_starts[poly];
    const int32_t n = m_.poly_sizes[poly];
    V3 normal_sum, up_sum;
    double mult = 0;
    for (int32_t i = 0; i < n; ++i) {
      normal_sum = normal_sum + v3(&m_.normals[3 * size_t(cv[i])]);
      up_sum = up_sum + v3(&up_[3 * size_t(cv[i])]);
      mult += multiplier(cv[i]);
    }
    Vec3f fallback_normal;
    store(fallback_normal.data(), normalized_or(normal_sum, V3{0, 0, 1}));
    V3 nf = v3(polygon_normal(m_, poly, fallback_normal));
    V3 up = normalized_or(project_to_plane(up_sum, nf),
                          normalized_or(project_to_plane(v3(&up_[3 * size_t(cv[0])]), nf), any_perpendicular(nf)));
    V3 right = cross(up, nf);
    const double s = p_.scale * mult / n;
    xy.resize(2 * size_t(n));
    V3 origin = pos(cv[0]);
    for (int32_t i = 0; i < n; ++i) {
      V3 e = pos(cv[i]) - origin;
      xy[2 * i] = dot(e, right) * s;
      xy[2 * i + 1] = -dot(e, up) * s;
    }
  }

  // Pass 1: per-vertex reach boxes (validity, §4.2.4) and oversized-face statistics.
  void measure_faces(SynthStats& st) {
    std::vector<double> xy;
    const double w = pre_.width, h = pre_.height;
    for (int32_t poly = 0; poly < m_.num_polys; ++poly) {
      face_offsets(poly, xy);
      const int32_t n = m_.poly_sizes[poly];
      double lo_x = 0, hi_x = 0, lo_y = 0, hi_y = 0;
      for (int32_t i = 0; i < n; ++i) {
        if (!std::isfinite(xy[2 * i]) || !std::isfinite(xy[2 * i + 1]))
          throw std::invalid_argument("scale " + std::to_string(p_.scale) + " makes texture offsets of face " +
                                      std::to_string(poly) + " overflow");
        lo_x = std::min(lo_x, xy[2 * i]), hi_x = std::max(hi_x, xy[2 * i]);
        lo_y = std::min(lo_y, xy[2 * i + 1]), hi_y = std::max(hi_y, xy[2 * i + 1]);
      }
      double ratio = std::max((hi_x - lo_x) / w, (hi_y - lo_y) / h);
      st.max_oversize_ratio = std::max(st.max_oversize_ratio, ratio);
      if (ratio > 1.0) ++st.oversized_faces;
      for (int32_t i = 0; i < n; ++i) {
        Box& b = reach_[m_.corner_verts[m_.poly_starts[poly] + i]];
        b.min_x = std::min(b.min_x, float(lo_x - xy[2 * i])), b.max_x = std::max(b.max_x, float(hi_x - xy[2 * i]));
        b.min_y = std::min(b.min_y, float(lo_y - xy[2 * i + 1])), b.max_y = std::max(b.max_y, float(hi_y - xy[2 * i + 1]));
      }
    }
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
    const float* ua = &up_[3 * size_t(a)];
    const float* ub = &up_[3 * size_t(b)];
    const float* ra = &right_[3 * size_t(a)];
    const float* rb = &right_[3 * size_t(b)];
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

  // Pass 2: the walk (§4.2.3–4.2.5). Sequential by nature; one RNG stream, so deterministic.
  void walk(const VertexOrder& order, SynthStats& st) {
    const int32_t k = pre_.jump_map.k;
    const int32_t width = pre_.width, height = pre_.height;
    const int32_t* targets = pre_.jump_map.targets.data();
    const float* weights = pre_.jump_map.weights.data();
    const float rate = float(p_.jump_rate);
    address_.assign(size_t(m_.num_vertices) * 2, std::numeric_limits<float>::quiet_NaN());
    std::vector<char> done(m_.num_vertices, 0);
    std::vector<Candidate> table;
    Rng rng(p_.seed, 0x6a756d70);  // "jump"
    for (int32_t v : order.order) {
      const Box& box = reach_[v];
      table.clear();
      double total = 0;
      int32_t synthesized = 0;
      auto add = [&](float x, float y, float w, bool jump) {
        if (w > 0.f && border_margin(x, y, box) >= 0.f) table.push_back({x, y, w, jump}), total += w;
      };
      for (int32_t kk = m_.neighbour_start[v]; kk < m_.neighbour_start[v + 1]; ++kk) {
        const int32_t j = m_.neighbours[kk];
        if (!done[j]) continue;
        ++synthesized;
        float dx, dy;
        edge_offset(j, v, dx, dy);
        const float ax = address_[2 * size_t(j)], ay = address_[2 * size_t(j) + 1];
        // Continuation ("do not jump"): weight jump_rate / |offset|, ramped down near the border.
        const float cx = ax + dx, cy = ay + dy;
        const float len = std::max(std::sqrt(dx * dx + dy * dy), 1e-3f);
        const float ramp = tileable_ ? 1.f : std::min(1.f, border_margin(cx, cy, box) / border_ramp_);
        add(cx, cy, rate / len * ramp, false);
        if (k == 0) continue;
        // Bilinear floating-point jump look-up at the neighbour's address (§4.2.3).
        const float fx = ax - 0.5f, fy = ay - 0.5f;
        const float x0 = std::floor(fx), y0 = std::floor(fy);
        const float tx = fx - x0, ty = fy - y0;
        for (int corner = 0; corner < 4; ++corner) {
          const int32_t xi = int32_t(x0) + (corner & 1), yi = int32_t(y0) + (corner >> 1);
          const float bw = ((corner & 1) ? tx : 1.f - tx) * ((corner >> 1) ? ty : 1.f - ty);
          if (bw <= 0.f) continue;
          int32_t qx = xi, qy = yi;
          if (tileable_) {
            qx = ((qx % width) + width) % width, qy = ((qy % height) + height) % height;
          } else if (qx < 0 || qy < 0 || qx >= width || qy >= height) {
            continue;
          }
          const size_t q = (size_t(qy) * width + qx) * k;
          for (int32_t s = 0; s < k; ++s) {
            const int32_t t = targets[q + s];
            if (t < 0) continue;
            const float ox = float(t % width - qx), oy = float(t / width - qy);
            add(cx + ox, cy + oy, weights[q + s] * bw, true);
          }
        }
      }
      float x, y;
      if (table.empty()) {
        random_address(rng, box, x, y);
        if (synthesized > 0) ++st.fallback_vertices;
      } else {
        double r = rng.uniform() * total;
        size_t pick = 0;
        while (pick + 1 < table.size() && r >= table[pick].weight) r -= table[pick++].weight;
        x = table[pick].x, y = table[pick].y;
        if (table[pick].jump) ++st.jumps;
      }
      if (tileable_) x -= W_ * std::floor(x / W_), y -= H_ * std::floor(y / H_);
      address_[2 * size_t(v)] = x, address_[2 * size_t(v) + 1] = y;
      done[v] = 1;
    }
  }

  // Pass 3: consistent per-polygon coordinates and blend sets (§4.3–4.4). Each polygon writes only
  // its own corners, so this is order-independent and runs in parallel.
  void write_corners(CornerMaps& out) const {
    const int32_t S = !p_.blend ? 1 : m_.all_triangles() ? 3 : 4;
    const size_t L = size_t(m_.num_corners);
    out.num_corners = m_.num_corners;
    out.num_blend_sets = S;
    out.base_uv.resize(L * 2);
    out.blend_uv.resize(size_t(S) * L * 2);
    out.blend_weights.assign(L * S, 0.f);
    const uint64_t poly_seed = splitmix64(p_.seed ^ 0x62617365ull);  // "base"
    tbb::parallel_for(tbb::blocked_range<int32_t>(0, m_.num_polys, 2048), [&](const tbb::blocked_range<int32_t>& range) {
      std::vector<double> xy;
      for (int32_t poly = range.begin(); poly < range.end(); ++poly) {
        face_offsets(poly, xy);
        const int32_t n = m_.poly_sizes[poly];
        const size_t first = size_t(m_.poly_starts[poly]);
        // Writes the polygon's mapping grown from corner `from` into uv (indexed by corner).
        auto grow = [&](int32_t from, float* uv) {
          const int32_t v = m_.corner_verts[first + from];
          const double ax = address_[2 * size_t(v)] - xy[2 * from], ay = address_[2 * size_t(v) + 1] - xy[2 * from + 1];
          for (int32_t i = 0; i < n; ++i) {
            double x = ax + xy[2 * i], y = ay + xy[2 * i + 1];
            if (!tileable_) x = std::clamp(x, 0.0, double(W_)), y = std::clamp(y, 0.0, double(H_));
            uv[2 * (first + i)] = float(x / W_);
            uv[2 * (first + i) + 1] = float(1.0 - y / H_);
          }
        };
        const int32_t base = int32_t(splitmix64(poly_seed + uint64_t(poly)) % uint64_t(n));
        grow(base, out.base_uv.data());
        for (int32_t set = 0; set < S; ++set) {
          float* uv = out.blend_uv.data() + size_t(set) * L * 2;
          if (S == 1) {
            grow(base, uv);
          } else if (n <= S) {
            grow(set < n ? set : base, uv);
          } else {
            grow(int32_t((int64_t(set) * n + S - 1) / S), uv);
          }
        }
        for (int32_t i = 0; i < n; ++i) {
          const int32_t set = S == 1 ? 0 : n <= S ? i : int32_t(int64_t(i) * S / n);
          out.blend_weights[(first + i) * S + set] = 1.f;
        }
      }
    });
  }

  const Preprocessed& pre_;
  const Mesh& m_;
  const JumpSynthParams& p_;
  const float W_, H_;
  const bool tileable_;
  float border_ramp_;
  std::vector<float> up_, right_, address_;
  std::vector<Box> reach_;
};

}  // namespace

JumpSynthResult synthesize_jumpmap(const Preprocessed& pre, const Mesh& mesh, const float* orientation,
                                   const JumpSynthParams& params) {
  const auto start = std::chrono::steady_clock::now();
  validate_preprocessed(pre);
  validate_params(mesh, orientation, params);
  JumpSynthResult r = Synthesizer(pre, mesh, orientation, params).run();
  r.stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

}  // namespace texsynth
