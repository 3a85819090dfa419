// SPDX-License-Identifier: GPL-3.0-or-later
// The synthesis half of round-neighbourhood synthesis (Chen & Dong 2008;
// docs/algorithms/round_neighbourhoods.md): sample pyramid, template neighbourhoods of the sample, then
// the levels coarsest first. See round_synth.hpp.
#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <queue>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

#include "round_internal.hpp"
#include "texsynth/common/errors.hpp"
#include "texsynth/common/rng.hpp"
#include "texsynth/image/blur.hpp"
#include "texsynth/image/image.hpp"
#include "texsynth/image/reduce.hpp"
#include "texsynth/mesh/vec_math.hpp"
#include "texsynth/mesh/vertex_fill.hpp"
#include "texsynth/surface/dilate.hpp"
#include "texsynth/synth/round_metric.hpp"
#include "texsynth/synth/round_synth.hpp"

namespace texsynth {
namespace {

using round_detail::Progress;
using round_detail::seconds_since;

constexpr double kTwoPi = 6.283185307179586476925;
// A template point (or ring bin) whose bilinear weights over coloured texels sum below this is
// uncoloured (docs/algorithms/round_neighbourhoods.md, "Ring-point colour").
constexpr float kMinColourWeight = 0.5f;
// Candidates are de-duplicated on a quarter-pixel lattice (and kept there).
constexpr int32_t kSub = 4;
// Finer-level passes, in this order of the 2x2 texel parities (x & 1) | (y & 1) << 1: the diagonal
// pair first, so the second half of each pass pair sees synthesized neighbours on both axes.
constexpr std::array<int, 4> kPassOrder = {0, 3, 1, 2};

// ---------------------------------------------------------------------------------------------
// Sample side

struct SampleLevel {
  int32_t w = 0, h = 0, c = 0;
  bool wrap = false;
  std::vector<float> px;  // h*w*c
  int K = 0, P = 0;
  // Per pixel, the template's colours around its centre (paper §5.3: precomputed once per sample),
  // channel-planar so the comparison loops run over k: feat[(y*w + x)*P*c + ch*P + k].
  std::vector<float> feat;
  // Candidate region in quarter pixels, inclusive: where all K rings fit inside (never the border
  // stripe), or the whole sample when it wraps.
  int32_t lo4x = 0, hi4x = 0, lo4y = 0, hi4y = 0;

  int32_t ix(int32_t x) const { return wrap ? ((x % w) + w) % w : std::clamp(x, 0, w - 1); }
  int32_t iy(int32_t y) const { return wrap ? ((y % h) + h) % h : std::clamp(y, 0, h - 1); }

  // Bilinear at continuous (X, Y) (pixel centres at +0.5), edge-clamped or wrapped.
  void bilinear(double X, double Y, float* out) const {
    const double fx = X - 0.5, fy = Y - 0.5;
    const double x0 = std::floor(fx), y0 = std::floor(fy);
    const float tx = float(fx - x0), ty = float(fy - y0);
    const int32_t xa = ix(int32_t(x0)), xb = ix(int32_t(x0) + 1), ya = iy(int32_t(y0)), yb = iy(int32_t(y0) + 1);
    const float* p00 = &px[(size_t(ya) * w + xa) * c];
    const float* p10 = &px[(size_t(ya) * w + xb) * c];
    const float* p01 = &px[(size_t(yb) * w + xa) * c];
    const float* p11 = &px[(size_t(yb) * w + xb) * c];
    for (int k = 0; k < c; ++k)
      out[k] = (p00[k] * (1 - tx) + p10[k] * tx) * (1 - ty) + (p01[k] * (1 - tx) + p11[k] * tx) * ty;
  }
};

std::vector<SampleLevel> build_pyramid(const RoundSample& s, const std::vector<int>& rings, bool wrap,
                                       double coarse_blur, double coarse_sharp_share,
                                       const std::atomic<bool>* cancel) {
  const int levels = int(rings.size());
  const int32_t step = int32_t(1) << (levels - 1);
  std::vector<SampleLevel> pyr(static_cast<size_t>(levels));
  const int32_t C = s.channels;
  pyr[0].w = s.width - s.width % step;
  pyr[0].h = s.height - s.height % step;
  pyr[0].c = C;
  pyr[0].px.resize(size_t(pyr[0].w) * pyr[0].h * C);
  for (int32_t y = 0; y < pyr[0].h; ++y)
    std::memcpy(&pyr[0].px[size_t(y) * pyr[0].w * C], s.pixels + size_t(y) * s.width * C,
                size_t(pyr[0].w) * C * sizeof(float));
  for (int l = 1; l < levels; ++l) {
    const SampleLevel& f = pyr[l - 1];
    SampleLevel& g = pyr[l];
    g.w = f.w / 2, g.h = f.h / 2, g.c = C;
    halve_image(f.px.data(), f.w, f.h, C, g.px);
  }
  if (levels > 1 && coarse_blur > 0) {
    // round_neighbourhoods.md, "Sparse structure": the sharp share keeps thin lines' positions.
    SampleLevel& g = pyr[size_t(levels - 1)];
    const std::vector<float> blurred = gaussian_blur(g.px.data(), g.w, g.h, C, coarse_blur, wrap, cancel);
    const float keep = float(coarse_sharp_share);
    for (size_t i = 0; i < g.px.size(); ++i) g.px[i] = keep * g.px[i] + (1 - keep) * blurred[i];
  }
  for (int l = 0; l < levels; ++l) {
    SampleLevel& g = pyr[l];
    g.wrap = wrap;
    g.K = rings[l];
    const RoundTemplate tmpl = round_template(g.K);
    g.P = tmpl.size();
    if (wrap) {
      g.lo4x = 0, g.hi4x = kSub * g.w - 1, g.lo4y = 0, g.hi4y = kSub * g.h - 1;
    } else {
      g.lo4x = kSub * g.K + kSub / 2, g.hi4x = kSub * (g.w - g.K) - kSub / 2;
      g.lo4y = kSub * g.K + kSub / 2, g.hi4y = kSub * (g.h - g.K) - kSub / 2;
    }
    g.feat.resize(size_t(g.w) * g.h * g.P * C);
    tbb::parallel_for(tbb::blocked_range<int32_t>(0, g.h, 8), [&](const tbb::blocked_range<int32_t>& r) {
      throw_if_cancelled(cancel);
      for (int32_t y = r.begin(); y < r.end(); ++y)
        for (int32_t x = 0; x < g.w; ++x) {
          float* out = &g.feat[(size_t(y) * g.w + x) * g.P * C];
          float v[4];
          for (int k = 0; k < g.P; ++k) {
            g.bilinear(x + 0.5 + tmpl.dx[k], y + 0.5 + tmpl.dy[k], v);
            for (int ch = 0; ch < C; ++ch) out[ch * g.P + k] = v[ch];
          }
        }
    });
  }
  return pyr;
}

// ---------------------------------------------------------------------------------------------
// Per-point field data

struct Frame {
  V3 n, up, right;  // right = up × n: sample +x
};

// Undefined (zero) vertex directions take the direction of the nearest defined vertex along mesh
// edges (breadth first from all defined vertices in index order: deterministic).
std::vector<float> fill_directions(const RoundSynthesisContext& ctx, const float* dirs) {
  const int32_t nv = ctx.num_vertices;
  std::vector<float> out(dirs, dirs + 3 * size_t(nv));
  std::vector<uint8_t> known(size_t(nv), 0);
  for (int32_t v = 0; v < nv; ++v) {
    const float* d = dirs + 3 * size_t(v);
    known[v] = d[0] != 0.f || d[1] != 0.f || d[2] != 0.f;
  }
  fill_from_known_vertices(ctx.vertex_adjacency_start.data(), ctx.vertex_adjacency.data(), nv, known, out.data());
  return out;
}

// ---------------------------------------------------------------------------------------------
// Level state and the per-point synthesis step

struct LevelState {
  int32_t n = 0;
  std::vector<float> colour;   // n*C: synthesized, or predicted from the level below
  std::vector<float> coord;    // n*2: source coordinate (this level's pixels)
  std::vector<uint8_t> has;    // colour/coord are set
  std::vector<float> angle;    // field angle from t0 (rings' frame)
  std::vector<float> next_colour, next_coord;  // results of the running pass, in pass order (finer levels)
};

struct Scratch {
  std::vector<float> bin_acc, bin_w;
  std::vector<int32_t> bin_dom;
  std::vector<float> bin_uv;         // image: 2 per entry, the ring point's UV
  std::vector<int32_t> bin_island;   // image: the ring point's UV island (-1: no point)
  std::vector<float> tmpl, weight;
  std::vector<int> valid;
  std::vector<int32_t> seen;
  std::vector<int32_t> cand;  // 2 per candidate, quarter pixels
  std::vector<uint64_t> table;  // candidate set: generation << 40 | key
  uint32_t generation = 0;
  std::vector<float> blend, dk, ring_ssd;  // ring_ssd: candidates × K
  AdaptiveScratch adaptive;
};

struct PointStats {
  int64_t candidates = 0, uncoloured = 0, templates = 0;
  std::array<int64_t, kMaxRings + 1> top{};
};

int max_degree(const RoundSynthesisContext& ctx) {
  int d = 0;
  if (ctx.target == RoundTarget::kVertices)
    for (int32_t v = 0; v < ctx.num_vertices; ++v)
      d = std::max(d, ctx.vertex_adjacency_start[v + 1] - ctx.vertex_adjacency_start[v]);
  return d;
}

class LevelSynth {
 public:
  LevelSynth(const RoundSynthesisContext& ctx, const RoundLevel& L, const SampleLevel& S, LevelState& st,
             const RoundSynthParams& p, bool coarsest)
      : ctx_(ctx), L_(L), S_(S), st_(st), p_(p), coarsest_(coarsest), C_(S.c), K_(L.rings),
        E_(ring_entries(L.rings)), tmpl_(round_template(L.rings)) {
    for (int k = 0; k < tmpl_.size(); ++k) {
      int m = 1;
      while (k >= tmpl_.ring_start[m]) ++m;
      tmpl_ring_.push_back(m);
      tmpl_bin_offset_.push_back(double(tmpl_.angle[k]) / kTwoPi * ring_bins(m));
    }
    // Hierarchical offsets, nearest first (after the prediction itself, which leads and wins ties).
    const int dr = p.dist_range;
    for (int j = -dr; j <= dr; ++j)
      for (int i = -dr; i <= dr; ++i) hier_.push_back({i, j});
    std::stable_sort(hier_.begin(), hier_.end(), [](const std::array<int, 2>& a, const std::array<int, 2>& b) {
      return a[0] * a[0] + a[1] * a[1] < b[0] * b[0] + b[1] * b[1];
    });
    max_candidates_ = 1 + E_ + int(hier_.size()) + std::max(2, p.random_candidates) + max_degree(ctx);
  }

  Frame frame(int32_t i) const {
    const V3 n = v3(&L_.rings_data.normal[3 * size_t(i)]), t0 = v3(&L_.rings_data.tangent[3 * size_t(i)]);
    const double a = st_.angle[i];
    const V3 up = t0 * std::cos(a) + cross(n, t0) * std::sin(a);
    return {n, up, cross(up, n)};
  }

  // Surface offset v (world) at point i -> sample offset (this level's pixels).
  std::array<double, 2> to_sample(const Frame& f, int32_t i, V3 v) const {
    const double inv_r = 1.0 / double(L_.radius[i]);
    return {dot(v, f.right) * inv_r, dot(v, f.up) * inv_r};
  }

  // One point: surface neighbourhood, candidates, adaptive metric. Writes the chosen source
  // coordinate and its colour.
  template <int C>
  void synthesize_point(int32_t i, Scratch& s, PointStats& ps, float* out_colour, float* out_coord) const {
    gather_bins<C>(i, s);
    const int P = tmpl_.size();
    // Template colours: linear between the two bins around each template angle (ring_sample).
    s.tmpl.assign(size_t(P) * C, 0.f);  // channel-planar, 0 where uncoloured
    s.weight.assign(size_t(P), 0.f);     // 1 where coloured
    s.valid.clear();
    const double turns = (double(st_.angle[i]) - kTwoPi / 4) / kTwoPi;  // sample +x is the field turned by -90°
    const bool image = ctx_.target == RoundTarget::kImage;
    float centre_u = 0, centre_v = 0;
    const int32_t centre_island = image && L_.triangle[i] >= 0 ? ctx_.triangle_island[L_.triangle[i]] : -1;
    if (centre_island >= 0) {
      const float* uv = &ctx_.corner_uvs[6 * size_t(L_.triangle[i])];
      const float b1 = L_.barycentric[2 * size_t(i)], b2 = L_.barycentric[2 * size_t(i) + 1], b0 = 1.f - b1 - b2;
      centre_u = b0 * uv[0] + b1 * uv[2] + b2 * uv[4], centre_v = b0 * uv[1] + b1 * uv[3] + b2 * uv[5];
    }
    for (int k = 0; k < P; ++k) {
      const int m = tmpl_ring_[k], bins = ring_bins(m);
      double x = turns * bins + tmpl_bin_offset_[k];
      x -= std::floor(x / bins) * bins;
      int b0 = int(x);
      float w = float(x - b0);
      if (b0 >= bins) b0 = 0, w = 0.f;
      const int b1 = b0 + 1 == bins ? 0 : b0 + 1;
      const int e0 = ring_offset(m) + b0, e1 = ring_offset(m) + b1;
      // Between two ring points of one island, the template point is read where it lies: the UV offsets
      // from the centre interpolated by angle (exact where the UV map is linear over the ring). Blending
      // the two bins' colours instead blurs by how far the field turns from the rings' reference tangent,
      // which comes from the triangulation.
      if (w > 0.f && centre_island >= 0 && s.bin_island[e0] == centre_island && s.bin_island[e1] == centre_island) {
        const double step = kTwoPi / bins, inv_sin = 1.0 / std::sin(step);
        const float a0 = float(std::sin((1.0 - w) * step) * inv_sin), a1 = float(std::sin(w * step) * inv_sin);
        const float u = centre_u + a0 * (s.bin_uv[2 * size_t(e0)] - centre_u) + a1 * (s.bin_uv[2 * size_t(e1)] - centre_u);
        const float v = centre_v + a0 * (s.bin_uv[2 * size_t(e0) + 1] - centre_v) +
                        a1 * (s.bin_uv[2 * size_t(e1) + 1] - centre_v);
        float acc[C] = {};
        float wsum = 0, wbest = 0;
        int32_t dom = -1;
        read_texels<C>(u, v, centre_island, acc, wsum, wbest, dom);
        if (wsum >= kMinColourWeight) {
          const float inv = 1.f / wsum;
          for (int c = 0; c < C; ++c) s.tmpl[size_t(c) * P + k] = acc[c] * inv;
          s.weight[k] = 1.f;
          s.valid.push_back(k);
          continue;
        }
      }
      const float W = (1 - w) * s.bin_w[e0] + w * s.bin_w[e1];
      if (!(W >= kMinColourWeight)) continue;
      const float inv = 1.f / W;
      for (int c = 0; c < C; ++c)
        s.tmpl[size_t(c) * P + k] = ((1 - w) * s.bin_acc[size_t(e0) * C + c] + w * s.bin_acc[size_t(e1) * C + c]) * inv;
      s.weight[k] = 1.f;
      s.valid.push_back(k);
    }
    ps.templates += P;
    ps.uncoloured += P - int64_t(s.valid.size());
    gather_candidates(i, s);
    const int n = int(s.cand.size() / 2);
    ps.candidates += n;
    int top = 0;
    const int best = choose<C>(s, n, &top);
    ++ps.top[size_t(top)];
    out_coord[0] = float(s.cand[2 * size_t(best)]) / kSub;
    out_coord[1] = float(s.cand[2 * size_t(best) + 1]) / kSub;
    S_.bilinear(out_coord[0], out_coord[1], out_colour);
  }

  // Prediction from the level below: the parent's source coordinate doubled plus this point's
  // offset from the parent, read in this level's sample.
  void predict(int32_t i, const RoundLevel& coarse, const LevelState& cs) {
    const int32_t pp = L_.parent[i];
    if (pp < 0 || !cs.has[pp]) {
      st_.has[i] = 0;
      return;
    }
    const Frame f = frame(i);
    const V3 v = v3(&L_.position[3 * size_t(i)]) - v3(&coarse.position[3 * size_t(pp)]);
    const std::array<double, 2> d = to_sample(f, i, v);
    double X = 2.0 * cs.coord[2 * size_t(pp)] + d[0], Y = 2.0 * cs.coord[2 * size_t(pp) + 1] + d[1];
    if (!L_.subpixel(i)) X = std::floor(X) + 0.5, Y = std::floor(Y) + 0.5;  // as its candidates
    st_.coord[2 * size_t(i)] = float(X);
    st_.coord[2 * size_t(i) + 1] = float(Y);
    S_.bilinear(X, Y, &st_.colour[size_t(i) * C_]);
    st_.has[i] = 1;
  }

 private:
  // Adds point q's colour with weight w (nothing when q has none yet); dom: the heaviest point so far.
  template <int C>
  void add_colour(int32_t q, float w, float* acc, float& wsum, float& wbest, int32_t& dom) const {
    if (q < 0 || w <= 0.f || !st_.has[q]) return;
    const float* col = &st_.colour[size_t(q) * C];
    for (int c = 0; c < C; ++c) acc[c] += w * col[c];
    wsum += w;
    if (w > wbest) wbest = w, dom = q;
  }

  // Image target: bilinear over this level's texels of one island at (u, v), unnormalised.
  template <int C>
  void read_texels(float u, float v, int32_t island, float* acc, float& wsum, float& wbest, int32_t& dom) const {
    const float X = u * float(L_.width) - 0.5f, Y = v * float(L_.height) - 0.5f;
    const float fx0 = std::floor(X), fy0 = std::floor(Y);
    const int32_t x0 = int32_t(fx0), y0 = int32_t(fy0);
    const float tx = X - fx0, ty = Y - fy0;
    for (int k = 0; k < 4; ++k) {
      const int32_t x = x0 + (k & 1), y = y0 + (k >> 1);
      if (x < 0 || y < 0 || x >= L_.width || y >= L_.height) continue;
      int32_t q = L_.texel_point[size_t(y) * L_.width + x];
      if (q < -1) q = -2 - q;  // gutter texel: its nearest covered texel
      if (q < 0 || L_.island[q] != island) continue;
      add_colour<C>(q, ((k & 1) ? tx : 1 - tx) * ((k >> 1) ? ty : 1 - ty), acc, wsum, wbest, dom);
    }
  }

  // Ring bins of point i: unnormalised colour sums, weights and the dominant coloured point.
  template <int C>
  void gather_bins(int32_t i, Scratch& s) const {
    s.bin_acc.assign(size_t(E_) * C, 0.f);
    s.bin_w.assign(size_t(E_), 0.f);
    s.bin_dom.assign(size_t(E_), -1);
    const RingPoint* block = L_.rings_data.point_block(i);
    const bool image = ctx_.target == RoundTarget::kImage;
    if (image) s.bin_uv.assign(2 * size_t(E_), 0.f), s.bin_island.assign(size_t(E_), -1);
    for (int e = 0; e < E_; ++e) {
      const RingPoint& rp = block[e];
      if (rp.triangle < 0) continue;
      const float b1 = rp.b1 * (1.f / 65535.f), b2 = rp.b2 * (1.f / 65535.f), b0 = 1.f - b1 - b2;
      float* acc = &s.bin_acc[size_t(e) * C];
      float wsum = 0, wbest = 0;
      int32_t dom = -1;
      if (image) {
        // (triangle, barycentrics) -> UV of that triangle -> bilinear over this level's texels of
        // the same island (a walk that crossed a seam reads the other island's texels).
        const int32_t island = ctx_.triangle_island[rp.triangle];
        if (island < 0) continue;
        const float* uv = &ctx_.corner_uvs[6 * size_t(rp.triangle)];
        const float u = b0 * uv[0] + b1 * uv[2] + b2 * uv[4], v = b0 * uv[1] + b1 * uv[3] + b2 * uv[5];
        s.bin_uv[2 * size_t(e)] = u, s.bin_uv[2 * size_t(e) + 1] = v, s.bin_island[e] = island;
        read_texels<C>(u, v, island, acc, wsum, wbest, dom);
      } else {
        auto add = [&](int32_t q, float w) { add_colour<C>(q, w, acc, wsum, wbest, dom); };
        const int32_t* c = &ctx_.triangles[3 * size_t(rp.triangle)];
        add(ctx_.vertex_point[c[0]], b0);
        add(ctx_.vertex_point[c[1]], b1);
        add(ctx_.vertex_point[c[2]], b2);
      }
      s.bin_w[e] = wsum;
      if (wsum >= kMinColourWeight) s.bin_dom[e] = dom;
    }
  }

  // Quantises (X, Y) (quarter pixels where the point is magnified, else the centre of the pixel
  // containing it), wraps or drops it outside the candidate region, and appends it unless an equal
  // candidate came earlier (open-addressing set, reset per point by a generation stamp).
  void push_candidate(Scratch& s, double X, double Y, bool subpixel) const {
    if (!(std::fabs(X) < 1e8 && std::fabs(Y) < 1e8)) return;  // also NaN
    int64_t x, y;
    if (subpixel) {
      x = int64_t(std::floor(X * kSub + 0.5)), y = int64_t(std::floor(Y * kSub + 0.5));
    } else {
      x = kSub * int64_t(std::floor(X)) + kSub / 2, y = kSub * int64_t(std::floor(Y)) + kSub / 2;
    }
    if (S_.wrap) {
      const int64_t W4 = int64_t(kSub) * S_.w, H4 = int64_t(kSub) * S_.h;
      x = ((x % W4) + W4) % W4;
      y = ((y % H4) + H4) % H4;
    } else if (x < S_.lo4x || x > S_.hi4x || y < S_.lo4y || y > S_.hi4y) {
      // Outside the region where the rings fit: dropped, not clamped (clamping piles coherent
      // proposals onto the region's edge and copies one row or column over and over).
      return;
    }
    const uint64_t key = (uint64_t(x) << 20 | uint64_t(y)) + 1;  // 40 bits, never 0
    const size_t mask = s.table.size() - 1;
    for (size_t h = size_t((key * 0x9E3779B97F4A7C15ull) >> 40) & mask;; h = (h + 1) & mask) {
      if ((s.table[h] >> 40) != s.generation) {  // empty slot: new candidate
        s.table[h] = uint64_t(s.generation) << 40 | key;
        s.cand.push_back(int32_t(x));
        s.cand.push_back(int32_t(y));
        return;
      }
      if ((s.table[h] & ((uint64_t(1) << 40) - 1)) == key) return;  // seen
    }
  }

  // Candidates in a fixed order (it breaks metric ties): the prediction, the coherence proposals of
  // the coloured ring bins (Ashikhmin: a neighbour copied from s proposes s + its offset to us), the
  // hierarchical window, random pixels (coarsest level, or when nothing else exists); each kept at
  // its first occurrence.
  void gather_candidates(int32_t i, Scratch& s) const {
    s.cand.clear();
    if (s.table.size() < size_t(4 * max_candidates_)) {
      size_t size = 64;
      while (size < size_t(4 * max_candidates_)) size *= 2;
      s.table.assign(size, 0);
    }
    if (++s.generation >= (1u << 24)) {
      std::fill(s.table.begin(), s.table.end(), 0);
      s.generation = 1;
    }
    const bool sub = L_.subpixel(i);
    const bool predicted = !coarsest_ && st_.has[i];
    const double cx = predicted ? st_.coord[2 * size_t(i)] : 0, cy = predicted ? st_.coord[2 * size_t(i) + 1] : 0;
    if (predicted) push_candidate(s, cx, cy, sub);
    const Frame f = frame(i);
    const V3 pi = v3(&L_.position[3 * size_t(i)]);
    s.seen.clear();
    auto propose_from = [&](int32_t q) {
      const std::array<double, 2> d = to_sample(f, i, pi - v3(&L_.position[3 * size_t(q)]));
      push_candidate(s, double(st_.coord[2 * size_t(q)]) + d[0], double(st_.coord[2 * size_t(q) + 1]) + d[1], sub);
    };
    if (ctx_.target == RoundTarget::kVertices) {
      // The mesh neighbours first: on the coarser levels the vertices are denser than r, so ring 1
      // (at distance r) passes over them, and without their proposals neighbouring vertices drift
      // apart in the sample.
      const int32_t v = L_.point_id[i];
      for (int32_t k = ctx_.vertex_adjacency_start[v]; k < ctx_.vertex_adjacency_start[v + 1]; ++k) {
        const int32_t q = ctx_.vertex_point[ctx_.vertex_adjacency[k]];
        if (q >= 0 && st_.has[q]) propose_from(q);
      }
    }
    for (int e = 0; e < E_; ++e) {
      const int32_t q = s.bin_dom[e];
      if (q < 0 || std::find(s.seen.begin(), s.seen.end(), q) != s.seen.end()) continue;
      s.seen.push_back(q);
      propose_from(q);
    }
    if (predicted) {
      // §6.3: the pixels within dist_range of the children of the parent's source pixel: the
      // pixel centres around the prediction (at the prediction's own phase where magnified).
      const double px = sub ? cx : std::floor(cx) + 0.5, py = sub ? cy : std::floor(cy) + 0.5;
      for (const std::array<int, 2>& h : hier_) push_candidate(s, px + h[0], py + h[1], sub);
    }
    // Random candidates (round_neighbourhoods.md, "Candidates") per sample pixel of surface, not
    // per point: where points are ρ times denser than r (the vertex target's coarser levels) a point
    // gets random_candidates / ρ² on average, else random sources would keep breaking up copies.
    Rng rng(p_.seed, (uint64_t(L_.level) << 40) ^ uint64_t(uint32_t(i)) ^ 0x726f756e64ull);
    int random = 0;
    if (coarsest_ && p_.random_candidates > 0) {
      const double rho = std::max(1.0, double(L_.density[i]));
      const double expected = p_.random_candidates / (rho * rho);
      random = int(expected) + (rng.uniform() < expected - std::floor(expected));
    }
    if (random > 0 || s.cand.empty()) {
      const int count = std::max(random, s.cand.empty() ? 2 : 0);
      const int32_t x0 = S_.lo4x / kSub, x1 = S_.hi4x / kSub, y0 = S_.lo4y / kSub, y1 = S_.hi4y / kSub;
      for (int k = 0; k < count; ++k) {
        const int32_t x = x0 + int32_t(rng.below(uint32_t(x1 - x0 + 1)));
        const int32_t y = y0 + int32_t(rng.below(uint32_t(y1 - y0 + 1)));
        push_candidate(s, x + 0.5, y + 0.5, false);  // pixel centres
      }
    }
  }

  // The sample template around candidate (x4, y4): a pointer into the precomputed table at a pixel
  // centre, else the bilinear mix of the four around it.
  template <int C>
  const float* candidate_features(int32_t x4, int32_t y4, Scratch& s) const {
    const int32_t P = S_.P;
    const int32_t ax = x4 - kSub / 2, ay = y4 - kSub / 2;  // pixel-index units × kSub
    const int32_t x0 = ax >= 0 ? ax / kSub : -((-ax + kSub - 1) / kSub), y0 = ay >= 0 ? ay / kSub : -((-ay + kSub - 1) / kSub);
    const int32_t rx = ax - x0 * kSub, ry = ay - y0 * kSub;
    auto at = [&](int32_t x, int32_t y) { return &S_.feat[(size_t(S_.iy(y)) * S_.w + S_.ix(x)) * P * C]; };
    if (rx == 0 && ry == 0) return at(x0, y0);
    const float tx = float(rx) / kSub, ty = float(ry) / kSub;
    const float w00 = (1 - tx) * (1 - ty), w10 = tx * (1 - ty), w01 = (1 - tx) * ty, w11 = tx * ty;
    const float *a = at(x0, y0), *b = at(x0 + 1, y0), *c = at(x0, y0 + 1), *d = at(x0 + 1, y0 + 1);
    s.blend.resize(size_t(P) * C);
    float* out = s.blend.data();
    for (int32_t o = 0; o < P * C; ++o) out[o] = w00 * a[o] + w10 * b[o] + w01 * c[o] + w11 * d[o];
    return out;
  }

  // Adaptive metric (§5.2; round_neighbourhoods.md, "Metric"). Per candidate and coloured template point
  // the squared colour difference, clamped at mean + 2σ of that candidate's differences (outliers: clamped,
  // not dropped, so every candidate keeps the same terms); per-ring sums D_m. The top size and the winner
  // from those sums: choose_by_adaptive_metric (round_metric.hpp), capped at the last ring with a coloured
  // point (<= K); ties go to the lowest index, i.e. the candidate order.
  template <int C>
  int choose(Scratch& s, int n, int* top_out) const {
    int last_ring = 0;
    for (int k : s.valid) last_ring = std::max(last_ring, tmpl_ring_[k]);
    if (last_ring == 0 || n == 1) {
      *top_out = last_ring == 0 ? 0 : 1;
      return 0;
    }
    std::array<bool, kMaxRings + 1> ring_coloured{};
    for (int k : s.valid) ring_coloured[size_t(tmpl_ring_[k])] = true;
    const int K = K_;
    s.ring_ssd.assign(size_t(n) * K, 0.f);
    const int P = tmpl_.size();
    s.dk.resize(size_t(P));
    float* dk = s.dk.data();
    const float* t = s.tmpl.data();
    const float* wt = s.weight.data();
    const double cnt = double(s.valid.size());
    for (int c = 0; c < n; ++c) {
      const float* f = candidate_features<C>(s.cand[2 * size_t(c)], s.cand[2 * size_t(c) + 1], s);
      // Element-wise over k (vectorised); uncoloured template points get weight 0.
      for (int k = 0; k < P; ++k) {
        float d = 0;
        for (int ch = 0; ch < C; ++ch) {
          const float e = t[ch * P + k] - f[ch * P + k];
          d += e * e;
        }
        dk[k] = d * wt[k];
      }
      double sum = 0, sum2 = 0;
      for (int k = 0; k < P; ++k) sum += dk[k], sum2 += double(dk[k]) * dk[k];
      const double mean = sum / cnt, var = std::max(0.0, sum2 / cnt - mean * mean);
      const float cap = var > 0 ? float(mean + 2 * std::sqrt(var)) : std::numeric_limits<float>::max();
      float* rs = &s.ring_ssd[size_t(c) * K];
      for (int m = 1; m <= K; ++m) {
        float acc = 0;
        for (int k = tmpl_.ring_start[m - 1]; k < tmpl_.ring_start[m]; ++k) acc += std::min(dk[k], cap);
        rs[m - 1] = acc;
      }
    }
    const AdaptiveChoice choice = choose_by_adaptive_metric(s.ring_ssd.data(), n, K, last_ring, ring_coloured.data(),
                                                            p_.min_top_size, p_.fixed_top_size, s.adaptive);
    *top_out = choice.top_size;
    return choice.winner;
  }

  const RoundSynthesisContext& ctx_;
  const RoundLevel& L_;
  const SampleLevel& S_;
  LevelState& st_;
  const RoundSynthParams& p_;
  bool coarsest_;
  int C_, K_, E_;
  RoundTemplate tmpl_;
  std::vector<int> tmpl_ring_;
  std::vector<double> tmpl_bin_offset_;
  std::vector<std::array<int, 2>> hier_;
  int max_candidates_ = 0;
};

void validate_sample(const RoundSynthesisContext& ctx, const RoundSample& s, const RoundSynthParams& p) {
  if (ctx.levels.empty()) throw std::invalid_argument("round synthesis: the context is empty");
  if (!s.pixels) throw std::invalid_argument("round synthesis: missing sample pixels");
  if (s.channels != 3 && s.channels != 4)
    throw std::invalid_argument("round synthesis: the sample must have 3 or 4 channels, got " +
                                std::to_string(s.channels));
  if (s.width < 1 || s.height < 1 || int64_t(s.width) * s.height > kMaxImagePixels)
    throw std::invalid_argument("round synthesis: sample size " + std::to_string(s.width) + " x " +
                                std::to_string(s.height) + " is out of range");
  const int levels = int(ctx.levels.size());
  const int32_t step = int32_t(1) << (levels - 1);
  for (const RoundLevel& L : ctx.levels) {
    const int32_t need = (2 * L.rings + 1) << L.level;  // the ring diameter at this level, in finest pixels
    const int32_t w = (s.width - s.width % step), h = (s.height - s.height % step);
    if (w < need || h < need)
      throw std::invalid_argument("round synthesis: a " + std::to_string(s.width) + " x " + std::to_string(s.height) +
                                  " sample is smaller than the " + std::to_string(L.rings) + "-ring neighbourhood of level " +
                                  std::to_string(L.level) + " (needs at least " + std::to_string(need) +
                                  " pixels per side after cropping to a multiple of " + std::to_string(step) + ")");
  }
  for (int64_t i = 0; i < int64_t(s.width) * s.height * s.channels; ++i)
    if (!std::isfinite(s.pixels[i]) || std::fabs(s.pixels[i]) > kMaxPixelMagnitude)
      throw std::invalid_argument("round synthesis: sample value " + std::to_string(i) + " is NaN, infinite or too large");
  if (p.random_candidates < 0 || p.random_candidates > kRoundMaxRandomCandidates)
    throw std::invalid_argument("round synthesis: random_candidates must be 0.." + std::to_string(kRoundMaxRandomCandidates));
  if (p.min_top_size < 1 || p.min_top_size > kMaxRings)
    throw std::invalid_argument("round synthesis: min_top_size must be 1.." + std::to_string(kMaxRings));
  if (p.fixed_top_size < 0 || p.fixed_top_size > kMaxRings)
    throw std::invalid_argument("round synthesis: fixed_top_size must be 0.." + std::to_string(kMaxRings));
  if (p.dist_range < 0 || p.dist_range > kRoundMaxDistRange)
    throw std::invalid_argument("round synthesis: dist_range must be 0.." + std::to_string(kRoundMaxDistRange));
  if (!(p.coarse_blur >= 0 && p.coarse_blur <= 8))
    throw std::invalid_argument("round synthesis: coarse_blur must be 0..8");
  if (!(p.coarse_sharp_share >= 0 && p.coarse_sharp_share <= 1))
    throw std::invalid_argument("round synthesis: coarse_sharp_share must be 0..1");
  if (!(p.max_megabytes > 0)) throw std::invalid_argument("round synthesis: max_megabytes must be > 0");
}

// Field angle per point of a level (direction_angle on the rings' frame): the directions
// interpolated in the point's triangle; undefined there (zero or along the normal) -> the corner with
// the largest weight, then world +Z, then +Y.
int64_t point_angles(const RoundSynthesisContext& ctx, const RoundLevel& L, const std::vector<float>& dirs,
                     std::vector<float>& angle, const std::atomic<bool>* cancel) {
  angle.resize(size_t(L.num_points));
  std::atomic<int64_t> undefined{0};
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, L.num_points, 4096), [&](const tbb::blocked_range<int32_t>& r) {
    throw_if_cancelled(cancel);
    int64_t local = 0;
    for (int32_t i = r.begin(); i < r.end(); ++i) {
      const int32_t* c = &ctx.triangles[3 * size_t(L.triangle[i])];
      const float b1 = L.barycentric[2 * size_t(i)], b2 = L.barycentric[2 * size_t(i) + 1], b0 = 1 - b1 - b2;
      float d[3];
      for (int k = 0; k < 3; ++k)
        d[k] = b0 * dirs[3 * size_t(c[0]) + k] + b1 * dirs[3 * size_t(c[1]) + k] + b2 * dirs[3 * size_t(c[2]) + k];
      bool ok = false;
      float a = direction_angle(L.rings_data, i, d, &ok);
      if (!ok) {
        ++local;
        const int corner = b0 >= b1 && b0 >= b2 ? 0 : (b1 >= b2 ? 1 : 2);
        a = direction_angle(L.rings_data, i, &dirs[3 * size_t(c[corner])], &ok);
        static const float kZ[3] = {0, 0, 1}, kY[3] = {0, 1, 0};
        if (!ok) a = direction_angle(L.rings_data, i, kZ, &ok);
        if (!ok) a = direction_angle(L.rings_data, i, kY, &ok);
      }
      angle[i] = a;
    }
    undefined += local;
  });
  return undefined.load();
}

template <int C>
void run_coarsest(LevelSynth& ls, const RoundLevel& L, LevelState& st, const RoundSynthParams& p, RoundLevelStats& out,
                  const Progress& progress, double p0, double p1) {
  const int32_t n = L.num_points;
  std::fill(st.has.begin(), st.has.end(), 0);
  // Reseeds take the next unsynthesized point of a seeded random permutation.
  std::vector<int32_t> perm(static_cast<size_t>(n));
  for (int32_t i = 0; i < n; ++i) perm[i] = i;
  Rng rng(p.seed, 0x636f61727365ull);
  for (int32_t i = n - 1; i > 0; --i) std::swap(perm[i], perm[rng.below(uint32_t(i + 1))]);
  // Coverage order (round_neighbourhoods.md, "Order"): the point with the most synthesized points
  // within 2r next; ties by lowest index (a max-heap of (count, -index) with stale entries skipped).
  std::vector<int32_t> count(size_t(n), 0);
  std::priority_queue<std::pair<int32_t, int32_t>> heap;
  size_t cursor = 0;
  Scratch s;
  PointStats ps;
  for (int32_t done = 0; done < n; ++done) {
    if ((done & 255) == 0) {
      throw_if_cancelled(p.cancel);
      progress.set(p0 + (p1 - p0) * double(done) / n);
    }
    int32_t i = -1;
    while (!heap.empty()) {
      const auto top = heap.top();
      heap.pop();
      const int32_t q = -top.second;
      if (!st.has[q] && count[q] == top.first) {
        i = q;
        break;
      }
    }
    if (i < 0) {
      while (st.has[perm[cursor]]) ++cursor;
      i = perm[cursor];
      ++out.reseeds;
    }
    ls.synthesize_point<C>(i, s, ps, &st.colour[size_t(i) * C], &st.coord[2 * size_t(i)]);
    st.has[i] = 1;
    for (int32_t k = L.cover_start[i]; k < L.cover_start[i + 1]; ++k) {
      const int32_t q = L.cover_list[k];
      if (st.has[q]) continue;
      heap.push({++count[q], -q});
    }
  }
  out.candidates_per_point = n ? double(ps.candidates) / n : 0;
  out.uncoloured_template_fraction = ps.templates ? double(ps.uncoloured) / double(ps.templates) : 0;
  for (int t = 0; t <= L.rings; ++t) out.top_size_histogram[size_t(t)] = ps.top[size_t(t)];
}

// Finer levels: every point first gets the prediction, then four passes; a pass reads colours and
// coordinates as they were before it began (results go to next_*, committed after the pass), so the
// bytes do not depend on how the pass is split over threads.
template <int C>
void run_fine(LevelSynth& ls, const RoundSynthesisContext& ctx, const RoundLevel& L, const RoundLevel& coarse,
              const LevelState& cs, LevelState& st, const RoundSynthParams& p, RoundLevelStats& out,
              const Progress& progress, double p0, double p1) {
  const int32_t n = L.num_points;
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, n, 4096), [&](const tbb::blocked_range<int32_t>& r) {
    throw_if_cancelled(p.cancel);
    for (int32_t i = r.begin(); i < r.end(); ++i) ls.predict(i, coarse, cs);
  });
  std::array<std::vector<int32_t>, 4> passes;
  for (int32_t i = 0; i < n; ++i) {
    const int32_t id = L.point_id[i];
    const int parity = ctx.target == RoundTarget::kImage ? ((id % L.width) & 1) | (((id / L.width) & 1) << 1) : (id & 3);
    passes[size_t(parity)].push_back(i);
  }
  size_t largest = 0;
  for (const auto& list : passes) largest = std::max(largest, list.size());
  st.next_colour.resize(largest * C);  // one pass's results at a time
  st.next_coord.resize(largest * 2);
  tbb::enumerable_thread_specific<Scratch> scratch;
  tbb::combinable<PointStats> stats;
  std::atomic<int64_t> done{0};
  for (int pass : kPassOrder) {
    const std::vector<int32_t>& list = passes[size_t(pass)];
    tbb::parallel_for(tbb::blocked_range<size_t>(0, list.size(), 256), [&](const tbb::blocked_range<size_t>& r) {
      throw_if_cancelled(p.cancel);
      Scratch& s = scratch.local();
      PointStats& ps = stats.local();
      for (size_t k = r.begin(); k < r.end(); ++k) {
        ls.synthesize_point<C>(list[k], s, ps, &st.next_colour[k * C], &st.next_coord[2 * k]);
      }
      const int64_t d = done.fetch_add(int64_t(r.size())) + int64_t(r.size());
      progress.set(p0 + (p1 - p0) * double(d) / std::max<int32_t>(1, n));
    });
    tbb::parallel_for(tbb::blocked_range<size_t>(0, list.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t k = r.begin(); k < r.end(); ++k) {
        const int32_t i = list[k];
        std::memcpy(&st.colour[size_t(i) * C], &st.next_colour[k * C], C * sizeof(float));
        std::memcpy(&st.coord[2 * size_t(i)], &st.next_coord[2 * k], 2 * sizeof(float));
        st.has[i] = 1;
      }
    });
  }
  PointStats total;
  stats.combine_each([&](const PointStats& ps) {
    total.candidates += ps.candidates, total.uncoloured += ps.uncoloured, total.templates += ps.templates;
    for (size_t t = 0; t < total.top.size(); ++t) total.top[t] += ps.top[t];
  });
  out.candidates_per_point = n ? double(total.candidates) / n : 0;
  out.uncoloured_template_fraction = total.templates ? double(total.uncoloured) / double(total.templates) : 0;
  for (int t = 0; t <= L.rings; ++t) out.top_size_histogram[size_t(t)] = total.top[size_t(t)];
  std::vector<float>().swap(st.next_colour);
  std::vector<float>().swap(st.next_coord);
}

template <int C>
RoundSynthResult synthesize(const RoundSynthesisContext& ctx, const RoundSample& sample, const float* directions,
                            const RoundSynthParams& p) {
  const auto t_start = std::chrono::steady_clock::now();
  const Progress progress(p.progress);
  progress.reset();
  RoundSynthResult res;
  res.channels = C;
  const int levels = int(ctx.levels.size());
  res.stats.levels.resize(size_t(levels));

  auto t0 = std::chrono::steady_clock::now();
  std::vector<int> rings;
  for (const RoundLevel& L : ctx.levels) rings.push_back(L.rings);
  const std::vector<SampleLevel> pyr = build_pyramid(sample, rings, p.tileable, p.coarse_blur, p.coarse_sharp_share, p.cancel);
  res.stats.sample_width = pyr[0].w;
  res.stats.sample_height = pyr[0].h;
  const std::vector<float> dirs = fill_directions(ctx, directions);
  std::vector<LevelState> state(static_cast<size_t>(levels));
  for (int l = 0; l < levels; ++l) {
    const RoundLevel& L = ctx.levels[l];
    LevelState& st = state[l];
    st.n = L.num_points;
    res.stats.undefined_directions += point_angles(ctx, L, dirs, st.angle, p.cancel);
  }
  res.stats.seconds_prepare = seconds_since(t0);
  progress.set(0.02);

  // Work weights for the progress bar: points × template size per level.
  std::vector<double> weight(static_cast<size_t>(levels));
  double total = 0;
  for (int l = 0; l < levels; ++l) total += weight[l] = double(ctx.levels[l].num_points) * 4 * rings[l] * rings[l];
  double at = 0.02;
  for (int l = levels - 1; l >= 0; --l) {
    t0 = std::chrono::steady_clock::now();
    const RoundLevel& L = ctx.levels[l];
    LevelState& st = state[l];
    st.colour.assign(size_t(L.num_points) * C, 0.f);
    st.coord.assign(size_t(L.num_points) * 2, 0.f);
    st.has.assign(size_t(L.num_points), 0);
    RoundLevelStats& ls_out = res.stats.levels[l];
    ls_out.points = L.num_points;
    ls_out.invalid_ring_fraction = L.rings_data.invalid_fraction();
    ls_out.top_size_histogram.assign(size_t(L.rings) + 1, 0);
    const bool coarsest = l == levels - 1;
    LevelSynth ls(ctx, L, pyr[l], st, p, coarsest);
    const double next = at + 0.96 * weight[l] / std::max(1.0, total);
    if (coarsest) {
      run_coarsest<C>(ls, L, st, p, ls_out, progress, at, next);
    } else {
      run_fine<C>(ls, ctx, L, ctx.levels[l + 1], state[l + 1], st, p, ls_out, progress, at, next);
      // The level below is no longer needed.
      state[l + 1] = LevelState();
    }
    at = next;
    ls_out.seconds = seconds_since(t0);
  }

  t0 = std::chrono::steady_clock::now();
  const RoundLevel& F = ctx.levels[0];
  LevelState& fs = state[0];
  res.num_points = F.num_points;
  res.point_id = F.point_id;
  res.colour = std::move(fs.colour);
  res.source = std::move(fs.coord);
  if (ctx.target == RoundTarget::kImage) {
    const size_t texels = size_t(ctx.width) * ctx.height;
    res.image.assign(texels * C, 0.f);
    res.mask.assign(texels, 0);
    for (int32_t i = 0; i < F.num_points; ++i) {
      std::memcpy(&res.image[size_t(F.point_id[i]) * C], &res.colour[size_t(i) * C], C * sizeof(float));
      res.mask[F.point_id[i]] = 1;
    }
    const MarginPixels margin = find_margin_pixels(res.mask.data(), ctx.width, ctx.height, ctx.margin, p.cancel);
    for (size_t k = 0; k < margin.pixel.size(); ++k) {
      std::memcpy(&res.image[size_t(margin.pixel[k]) * C], &res.image[size_t(margin.source[k]) * C], C * sizeof(float));
      res.mask[margin.pixel[k]] = 2;
    }
  }
  res.stats.seconds_output = seconds_since(t0);
  res.stats.seconds_total = seconds_since(t_start);
  progress.set(1);
  return res;
}

}  // namespace

namespace round_detail {

int64_t estimate_synthesis_bytes(const RoundSynthesisContext& ctx, int64_t sample_w, int64_t sample_h, int channels) {
  const int64_t C = channels;
  int64_t bytes = ctx.num_vertices * int64_t(3 * 4 + 4 + 1);  // filled directions, BFS queue, flags
  int64_t w = sample_w, h = sample_h;
  int64_t state_peak = 0, state_prev = 0;
  for (const RoundLevel& L : ctx.levels) {
    const int64_t P = 4 * int64_t(L.rings) * L.rings;
    bytes += w * h * C * 4 * (1 + P);  // pyramid level + template table
    w /= 2, h /= 2;
    // colour, coord, has, angle, the pass lists and one pass's results (about n / 4) while the
    // level runs; the level below stays alive.
    const int64_t n = L.num_points;
    const int64_t st = n * ((C + 2) * 4 + 1 + 4);
    state_peak = std::max(state_peak, st + (n / 4 + 1024) * (C + 2) * 4 + state_prev + n * 4);
    state_prev = st;
  }
  bytes += state_peak;
  if (ctx.target == RoundTarget::kImage) bytes += int64_t(ctx.width) * ctx.height * (C * 4 + 1 + 8);  // image, mask, margin
  return bytes;
}

}  // namespace round_detail

RoundSynthResult synthesize_round(const RoundSynthesisContext& ctx, const RoundSample& sample, const float* directions,
                                  const RoundSynthParams& p) {
  validate_sample(ctx, sample, p);
  if (!directions) throw std::invalid_argument("round synthesis: missing directions");
  for (int64_t i = 0; i < int64_t(ctx.num_vertices) * 3; ++i)
    if (!std::isfinite(directions[i]))
      throw std::invalid_argument("round synthesis: direction of vertex " + std::to_string(i / 3) + " is NaN or infinite");
  const int64_t bytes =
      ctx.context_bytes + round_detail::estimate_synthesis_bytes(ctx, sample.width, sample.height, sample.channels);
  if (double(bytes) > p.max_megabytes * 1e6) {
    std::ostringstream msg;
    msg << "round synthesis: the context plus a " << sample.width << " x " << sample.height << " sample need about "
        << std::llround(double(bytes) / 1e6) << " MB (limit " << p.max_megabytes << " MB); use a smaller sample";
    throw std::invalid_argument(msg.str());
  }
  throw_if_cancelled(p.cancel);
  RoundSynthResult r = sample.channels == 3 ? synthesize<3>(ctx, sample, directions, p)
                                            : synthesize<4>(ctx, sample, directions, p);
  r.stats.estimated_bytes = bytes;
  return r;
}

}  // namespace texsynth
