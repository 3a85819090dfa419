// SPDX-License-Identifier: GPL-3.0-or-later
// Texton strings, bucket voting and Eq. 2 refinement (Magda & Kriegman §3.2.2).
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "texsynth/common/rng.hpp"
#include "texsynth/synth/texton_synth.hpp"

namespace texsynth {
namespace {

inline int32_t wrap_index(int32_t v, int32_t n) {
  v %= n;
  return v < 0 ? v + n : v;
}
inline int32_t clamp_index(int32_t v, int32_t n) { return v < 0 ? 0 : v >= n ? n - 1 : v; }
// Texel coordinate -> pixel index along one axis (floor; NaN-safe via the clamp).
inline int32_t texel_index(float c, int32_t n, bool wrap) {
  const float f = std::floor(c);
  if (!(f > -1e9f && f < 1e9f)) return 0;
  return wrap ? wrap_index(int32_t(f), n) : clamp_index(int32_t(f), n);
}

}  // namespace

void append_edge_string(const Preprocessed& pre, const float o_a[2], const float o_b[2], const float t_a[2],
                        const float t_b[2], const float phase[2], TextonString& out) {
  const float ex = o_b[0] - o_a[0], ey = o_b[1] - o_a[1];
  const float len = std::sqrt(ex * ex + ey * ey);
  const int32_t cap = 4 * std::max(pre.width, pre.height);
  const int32_t count = len < 1.f ? 1 : len < float(cap) ? int32_t(std::ceil(len)) : cap;
  const bool wrap = pre.params.tileable;
  for (int32_t i = 0; i < count; ++i) {
    const float t = (float(i) + 0.5f) / float(count);
    const float qx = t_a[0] + t * (t_b[0] - t_a[0]), qy = t_a[1] + t * (t_b[1] - t_a[1]);
    const int32_t px = texel_index(qx, pre.width, wrap), py = texel_index(qy, pre.height, wrap);
    out.label.push_back(pre.texton_map[size_t(py) * pre.width + px]);
    out.dx.push_back(int32_t(std::floor(phase[0] + o_a[0] + t * ex)));
    out.dy.push_back(int32_t(std::floor(phase[1] + o_a[1] + t * ey)));
  }
}

namespace {

// Eq. 2, stopping as soon as the sum exceeds `bound` (the caller then only needs "> bound").
double bounded_string_error(const Preprocessed& pre, const TextonString& s, int32_t x, int32_t y, bool wrap,
                            double bound) {
  const int32_t W = pre.width, H = pre.height, K = pre.num_textons;
  const float* dist = pre.texton_distances.data();
  double e = 0;
  for (size_t k = 0; k < s.size() && e <= bound; ++k) {
    const int32_t px = wrap ? wrap_index(x + s.dx[k], W) : clamp_index(x + s.dx[k], W);
    const int32_t py = wrap ? wrap_index(y + s.dy[k], H) : clamp_index(y + s.dy[k], H);
    e += dist[size_t(pre.texton_map[size_t(py) * W + px]) * K + s.label[k]];
  }
  return e;
}

}  // namespace

double string_error(const Preprocessed& pre, const TextonString& s, int32_t x, int32_t y, bool wrap) {
  return bounded_string_error(pre, s, x, y, wrap, std::numeric_limits<double>::infinity());
}

bool coherent_origin(const Preprocessed& pre, const TextonString& s, const int32_t* xy, int count,
                     const OriginRange& range, double max_error, int32_t& x, int32_t& y, double& error) {
  double best = max_error;
  bool found = false;
  for (int i = 0; i < count; ++i) {
    const int32_t cx = xy[2 * i], cy = xy[2 * i + 1];
    if (!range.wrap && (cx < range.x0 || cx > range.x1 || cy < range.y0 || cy > range.y1)) continue;
    // Bounded: a candidate is dropped as soon as its sum reaches the best (or the threshold).
    const double e = bounded_string_error(pre, s, cx, cy, range.wrap, best);
    if (e < best) best = e, x = cx, y = cy, error = e, found = true;
  }
  return found;
}

TextonSearch::TextonSearch(const Preprocessed& pre) : pre_(pre) {
  if (pre.width > 32000 || pre.height > 32000)
    throw std::invalid_argument("texton synthesis supports samples up to 32000 pixels per side");
  stride_ = pre.width + 2;
  counts_.assign(size_t(stride_) * (pre.height + 2), 0);
  bucket_x_.resize(pre.bucket_pixels.size());
  bucket_y_.resize(pre.bucket_pixels.size());
  for (size_t i = 0; i < pre.bucket_pixels.size(); ++i) {
    bucket_x_[i] = int16_t(pre.bucket_pixels[i] % pre.width);
    bucket_y_[i] = int16_t(pre.bucket_pixels[i] / pre.width);
  }
}

bool TextonSearch::search(const TextonString& s, const OriginRange& range, const SearchParams& sp, uint64_t tie_seed,
                          int32_t& x, int32_t& y, double& error) {
  const int32_t W = pre_.width, H = pre_.height;
  const size_t n = s.size();
  if (n == 0 || sp.top_m < 1 || sp.max_vote_points < 1 || sp.max_votes < 1) return false;
  // Counters cover origins [-1, W] x [-1, H] (a face inside the sample has its origin there); an
  // oversized face's centred range may lie outside: nothing to count then.
  const OriginRange r = range.wrap ? OriginRange{0, W - 1, 0, H - 1, true}
                                   : OriginRange{std::max(range.x0, -1), std::min(range.x1, W),
                                                 std::max(range.y0, -1), std::min(range.y1, H), false};
  if (r.x1 < r.x0 || r.y1 < r.y0) return false;
  // Voters: the string points with the rarest textons first (smallest buckets: the most telling
  // and the cheapest), while their buckets fit the vote budget; at least one point, whose bucket
  // is strided when it alone exceeds the budget. Counters are indexed by origin.
  auto bucket_size = [&](size_t k) { return size_t(pre_.bucket_start[s.label[k] + 1] - pre_.bucket_start[s.label[k]]); };
  voters_.resize(n);
  for (size_t k = 0; k < n; ++k) voters_[k] = uint32_t(k);
  const size_t max_voters = std::min({n, size_t(sp.max_vote_points), size_t(255)});  // uint8 counters
  auto rarer = [&](uint32_t a, uint32_t b) {
    const size_t sa = bucket_size(a), sb = bucket_size(b);
    return sa != sb ? sa < sb : a < b;
  };
  std::partial_sort(voters_.begin(), voters_.begin() + max_voters, voters_.end(), rarer);
  size_t voters = 0, votes = 0;
  while (voters < max_voters && (voters == 0 || votes + bucket_size(voters_[voters]) <= size_t(sp.max_votes)))
    votes += bucket_size(voters_[voters++]);
  const int32_t step = votes > size_t(sp.max_votes) ? int32_t((votes + sp.max_votes - 1) / sp.max_votes) : 1;
  if (touched_.size() < votes) touched_.resize(votes);  // every vote may touch a new origin
  int32_t* touched = touched_.data();
  size_t nt = 0;
  const uint32_t span_x = uint32_t(r.x1 - r.x0), span_y = uint32_t(r.y1 - r.y0);
  const int16_t* bx = bucket_x_.data();
  const int16_t* by = bucket_y_.data();
  // Locals: counters are uint8 (char aliases everything), members would be reloaded every vote.
  uint8_t* const counts = counts_.data();
  const int32_t stride = stride_;
  for (size_t j = 0; j < voters; ++j) {
    const size_t k = voters_[j];
    const int32_t t = s.label[k];
    const int32_t begin = pre_.bucket_start[t], end = pre_.bucket_start[t + 1];
    if (r.wrap) {
      const int32_t dx = wrap_index(s.dx[k], W), dy = wrap_index(s.dy[k], H);
      for (int32_t i = begin; i < end; i += step) {
        int32_t ox = bx[i] - dx, oy = by[i] - dy;
        ox += ox < 0 ? W : 0, oy += oy < 0 ? H : 0;
        const int32_t idx = (oy + 1) * stride + ox + 1;
        touched[nt] = idx;
        nt += counts[idx]++ == 0;
      }
    } else {
      const int32_t dx = s.dx[k], dy = s.dy[k];
      for (int32_t i = begin; i < end; i += step) {
        const int32_t ox = bx[i] - dx, oy = by[i] - dy;
        // Unsigned differences: no signed overflow even for offsets near the 1e9 limit.
        if (uint32_t(ox) - uint32_t(r.x0) > span_x || uint32_t(oy) - uint32_t(r.y0) > span_y) continue;
        const int32_t idx = (oy + 1) * stride + ox + 1;
        touched[nt] = idx;
        nt += counts[idx]++ == 0;
      }
    }
  }
  if (nt == 0) return false;
  // Top m by (count, seeded hash): the hash spreads count ties over the sample.
  struct Cand {
    uint64_t key;
    int32_t idx;
  };
  Cand best[64];
  const int m = std::min(sp.top_m, 64);
  int filled = 0;
  for (size_t i = 0; i < nt; ++i) {
    const int32_t idx = touched[i];
    const uint64_t count = counts_[idx];
    counts_[idx] = 0;
    if (filled == m && count < (best[m - 1].key >> 32)) continue;  // cheap reject before hashing
    const uint64_t key = (count << 32) | (splitmix64(tie_seed + uint64_t(idx)) >> 32);
    if (filled == m && key <= best[m - 1].key) continue;
    int pos = filled < m ? filled++ : m - 1;
    while (pos > 0 && best[pos - 1].key < key) best[pos] = best[pos - 1], --pos;
    best[pos] = {key, idx};
  }
  // Eq. 2 on the full string; uniform choice among near-ties.
  double err[64];
  double min_err = std::numeric_limits<double>::infinity();
  for (int i = 0; i < filled; ++i) {
    const int32_t ox = best[i].idx % stride_ - 1, oy = best[i].idx / stride_ - 1;
    // Candidates beyond min·(1 + tolerance) can be neither the minimum nor a near-tie: stop early.
    err[i] = bounded_string_error(pre_, s, ox, oy, range.wrap, min_err * (1.0 + sp.tie_tolerance));
    min_err = std::min(min_err, err[i]);
  }
  const double limit = min_err * (1.0 + sp.tie_tolerance);
  int ties = 0;
  for (int i = 0; i < filled; ++i) ties += err[i] <= limit;
  int pick = ties > 1 ? int(Rng(tie_seed, 0x74696573).below(uint32_t(ties))) : 0;
  for (int i = 0; i < filled; ++i) {
    if (err[i] > limit) continue;
    if (pick-- == 0) {
      x = best[i].idx % stride_ - 1, y = best[i].idx / stride_ - 1, error = err[i];
      return true;
    }
  }
  return false;  // unreachable: min_err is attained
}

}  // namespace texsynth
