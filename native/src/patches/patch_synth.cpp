// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/patches/patch_synth.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Dense>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <queue>
#include <utility>
#include <stdexcept>
#include <string>

#include "texsynth/common/errors.hpp"
#include "texsynth/common/hash.hpp"
#include "texsynth/common/rng.hpp"
#include "texsynth/image/reduce.hpp"
#include "texsynth/mesh/spatial_cells.hpp"

namespace texsynth {
namespace {

constexpr float kKnownWeight = 0.25f;
constexpr double kWindowKnownFraction = 1.0;  // a window with an unknown point is an unknown cell
// ... unless no cell near the frontier is fully known (a thin sliver of settled samples): then windows
// this full are used, mean-filled, rather than pasting a random patch.
constexpr double kSparseWindowKnownFraction = 0.5;
constexpr double kStopChanged = 0.01;

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Bilinear read of the exemplar at continuous pixel coordinates (pixel x covers [x, x + 1)).
class ExemplarReader {
 public:
  explicit ExemplarReader(const ExemplarSample& s, bool tileable) : s_(s), tileable_(tileable) {}
  void read(double x, double y, float* out) const {
    x -= 0.5, y -= 0.5;
    const double fx = std::floor(x), fy = std::floor(y);
    const float ax = float(x - fx), ay = float(y - fy);
    const int32_t x0 = int32_t(fx), y0 = int32_t(fy);
    const int C = s_.channels;
    for (int c = 0; c < C; ++c) out[c] = 0.f;
    for (int k = 0; k < 4; ++k) {
      const int32_t px = wrap(x0 + (k & 1), s_.width), py = wrap(y0 + (k >> 1), s_.height);
      const float w = ((k & 1) ? ax : 1 - ax) * ((k >> 1) ? ay : 1 - ay);
      const float* p = s_.pixels + (size_t(py) * size_t(s_.width) + size_t(px)) * size_t(C);
      for (int c = 0; c < C; ++c) out[c] += w * p[c];
    }
  }
  int channels() const { return s_.channels; }

 private:
  int32_t wrap(int32_t v, int32_t n) const {
    if (tileable_) return ((v % n) + n) % n;
    return std::clamp(v, 0, n - 1);
  }
  const ExemplarSample& s_;
  bool tileable_;
};

// One patch's view of the surface: the settled colours splatted onto its grid.
struct GridColours {
  GridColours(int32_t n_, int C_) : n(n_), C(C_) {}
  int32_t n = 0;
  int C = 0;
  std::vector<float> colour, weight;
  void splat(const PatchCoverage& cov, int32_t p, const std::vector<float>& colours, const std::vector<uint8_t>& settled) {
    colour.assign(size_t(n) * n * C, 0.f);
    weight.assign(size_t(n) * n, 0.f);
    for (int64_t e = cov.patch_start[p]; e < cov.patch_start[size_t(p) + 1]; ++e) {
      const float u = cov.patch_uv[2 * e], v = cov.patch_uv[2 * e + 1];
      const int32_t s = cov.patch_sample[e];
      if (!settled[s]) continue;
      const int32_t i = std::min(int32_t(u), n - 2), j = std::min(int32_t(v), n - 2);
      const float au = u - float(i), av = v - float(j);
      for (int k = 0; k < 4; ++k) {
        const float w = ((k & 1) ? au : 1 - au) * ((k >> 1) ? av : 1 - av);
        const size_t g = size_t(j + (k >> 1)) * n + size_t(i + (k & 1));
        weight[g] += w;
        for (int c = 0; c < C; ++c) colour[g * C + c] += w * colours[size_t(s) * C + c];
      }
    }
    for (size_t g = 0; g < weight.size(); ++g)
      if (weight[g] >= kKnownWeight)
        for (int c = 0; c < C; ++c) colour[g * C + c] /= weight[g];
  }
  bool known(int32_t i, int32_t j) const { return weight[size_t(j) * n + size_t(i)] >= kKnownWeight; }
  const float* at(int32_t i, int32_t j) const { return &colour[(size_t(j) * n + size_t(i)) * C]; }
};

// The query of one patch for `index`: raw appearance per cell and a known mask.
void patch_query(const GridColours& g, const PatchIndex& index, const AppearanceSpace& space, std::vector<float>& raw,
                 std::vector<uint8_t>& valid, std::vector<float>& window, double known_fraction = kWindowKnownFraction) {
  const int d = index.appearance_dims, C = g.C;
  raw.assign(index.cells.size() * size_t(d), 0.f);
  valid.assign(index.cells.size(), 0);
  window.resize(25 * size_t(C));
  for (size_t k = 0; k < index.cells.size(); ++k) {
    const int32_t ci = index.cells[k][0] + kPatchGridMargin, cj = index.cells[k][1] + kPatchGridMargin;
    int known = 0;
    std::vector<double> mean(size_t(C), 0.0);
    for (int dy = -2; dy <= 2; ++dy)
      for (int dx = -2; dx <= 2; ++dx)
        if (g.known(ci + dx, cj + dy)) {
          ++known;
          for (int c = 0; c < C; ++c) mean[c] += g.at(ci + dx, cj + dy)[c];
        }
    if (known < known_fraction * 25) continue;
    for (int c = 0; c < C; ++c) mean[c] /= known;
    for (int dy = -2; dy <= 2; ++dy)
      for (int dx = -2; dx <= 2; ++dx) {
        float* w = &window[(size_t(dy + 2) * 5 + size_t(dx + 2)) * C];
        const bool in = g.known(ci + dx, cj + dy);
        for (int c = 0; c < C; ++c) w[c] = in ? g.at(ci + dx, cj + dy)[c] : float(mean[c]);
      }
    space.project(window.data(), &raw[k * size_t(d)]);
    valid[k] = 1;
  }
}

// dist[r] += |f_c(r)|² − 2 q·f_c(r) for one cell c over `count` rows: norm[r] = |f_c(r)|², columns holds
// the cell's d feature columns `stride` apart. Plain loops the compiler vectorises (an AVX2 clone of
// this kernel measured within the noise of the x86-64 baseline).
void accumulate_cell(float* dist, const float* norm, const float* columns, int64_t stride, const float* q, int d,
                     int64_t count) {
  for (int64_t r = 0; r < count; ++r) dist[r] += norm[r];
  for (int e = 0; e < d; ++e) {
    const float w = -2.f * q[e];
    const float* col = columns + int64_t(e) * stride;
    for (int64_t r = 0; r < count; ++r) dist[r] += w * col[r];
  }
}

// Shortlist by the index (or every origin, exact, when `exhaustive`), rerank by exact distance over the known cells. Returns (id, distance²) sorted.
// Exact distance over the known cells between a query and one origin's raw features.
double masked_distance(const PatchIndex& index, const ExemplarAppearance& app, const std::vector<float>& raw,
                       const std::vector<uint8_t>& valid, int32_t id, std::vector<float>& feature) {
  feature.resize(raw.size());
  index.raw_feature(app, id, feature.data());
  const int d = index.appearance_dims;
  double dist = 0;
  for (size_t c = 0; c < valid.size(); ++c)
    if (valid[c])
      for (int e = 0; e < d; ++e) {
        const double diff = double(feature[c * d + e]) - raw[c * d + e];
        dist += diff * diff;
      }
  return dist;
}

std::vector<std::pair<double, int32_t>> ranked_candidates(const PatchIndex& index, const ExemplarAppearance& app,
                                                          const std::vector<float>& raw,
                                                          const std::vector<uint8_t>& valid, int k,
                                                          bool exhaustive,
                                                          std::vector<float>& reduced, std::vector<float>& feature) {
  std::vector<std::pair<double, int32_t>> out;
  if (exhaustive) {
    // Exact distance over the known cells, Σ m f² − 2 f·(m q) + Σ m q², cell by cell: each known cell
    // reads its own contiguous column block only. The search is bound by memory traffic: rows go in
    // blocks (a block's distances stay in cache over the cells) on every core; a coarse search over every
    // other origin was 2.8x faster but lost detail (moss 0.82 -> 0.69 of the sample's gradient after
    // optimisation, README).
    const int d = index.appearance_dims;
    const Eigen::Index total = index.count();
    reduced.resize(size_t(total));  // scratch: kept between calls, no page faults per query
    Eigen::Map<Eigen::VectorXf> dist(reduced.data(), total);
    double qq = 0;
    for (size_t c = 0; c < valid.size(); ++c)
      if (valid[c]) qq += double(Eigen::Map<const Eigen::VectorXf>(raw.data() + c * d, d).squaredNorm());
    constexpr Eigen::Index kBlock = 2048;
    tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, (total + kBlock - 1) / kBlock, 1),
                      [&](const tbb::blocked_range<Eigen::Index>& r) {
      for (Eigen::Index b = r.begin(); b < r.end(); ++b) {
        const Eigen::Index row = b * kBlock, count = std::min(kBlock, total - row);
        float* segment = dist.data() + row;
        std::fill_n(segment, count, 0.f);
        for (size_t c = 0; c < valid.size(); ++c)
          if (valid[c])
            accumulate_cell(segment, index.cell_norm.data() + int64_t(c) * total + row,
                            index.columns.data() + int64_t(c) * d * total + row, total, raw.data() + c * d, d, count);
      }
    });
    // The k smallest (distance, id) in one pass: a max-heap of the best so far, most rows rejected by
    // one comparison with its top.
    const size_t keep = std::min(size_t(total), size_t(k));
    std::vector<std::pair<float, int32_t>> best;
    best.reserve(keep + 1);
    for (Eigen::Index r = 0; r < total; ++r) {
      const std::pair<float, int32_t> item{dist[r], int32_t(r)};
      if (best.size() < keep) {
        best.push_back(item);
        std::push_heap(best.begin(), best.end());
      } else if (item < best.front()) {
        std::pop_heap(best.begin(), best.end());
        best.back() = item;
        std::push_heap(best.begin(), best.end());
      }
    }
    std::sort_heap(best.begin(), best.end());
    out.reserve(keep);
    for (const auto& [d2, id] : best) out.push_back({std::max(0.0, double(d2) + qq), id});
    return out;
  }
  reduced.resize(size_t(index.dims));
  index.project(raw.data(), valid.data(), reduced.data());
  const std::vector<PatchMatch> shortlist = index.search(reduced.data(), k);
  for (const PatchMatch& m : shortlist) {
    const int32_t id = m.y * index.origins_x + m.x;
    out.push_back({masked_distance(index, app, raw, valid, id, feature), id});
  }
  std::sort(out.begin(), out.end());
  return out;
}

// Optimisation's M-step also tries the origins the patch's current exemplar coordinates imply (the
// copies already under it, at most kCoherent, the most common first). Without them a patch straddling
// two pasted pieces matched a plain region (no exact match; L2 prefers the mean) and plain regions
// spread level by level: dried mud kept 0.41 of sampling's detail, sparse cracks gone (issue 29).
constexpr size_t kCoherent = 8;
void coherent_candidates(const PatchCoverage& cov, int32_t q, const std::vector<float>& source, const PatchIndex& index,
                         std::vector<int32_t>& ids) {
  ids.clear();
  for (int64_t e = cov.patch_start[q]; e < cov.patch_start[size_t(q) + 1]; ++e) {
    const int32_t s = cov.patch_sample[e];
    const float sx = source[2 * size_t(s)], sy = source[2 * size_t(s) + 1];
    if (!(sx >= 0 && sy >= 0)) continue;
    const int32_t ox = int32_t(std::lround(sx - 0.5 - (cov.patch_uv[2 * e] - kPatchGridMargin)));
    const int32_t oy = int32_t(std::lround(sy - 0.5 - (cov.patch_uv[2 * e + 1] - kPatchGridMargin)));
    if (ox < 0 || oy < 0 || ox >= index.origins_x || oy >= index.origins_y) continue;
    ids.push_back(oy * index.origins_x + ox);
  }
  std::sort(ids.begin(), ids.end());
  std::vector<std::pair<int64_t, int32_t>> runs;  // (-count, id): the most common first, ties by id
  for (size_t a = 0; a < ids.size();) {
    size_t b = a;
    while (b < ids.size() && ids[b] == ids[a]) ++b;
    runs.push_back({-int64_t(b - a), ids[a]});
    a = b;
  }
  std::sort(runs.begin(), runs.end());
  ids.clear();
  for (size_t k = 0; k < runs.size() && k < kCoherent; ++k) ids.push_back(runs[k].second);
}

// Per grid point, the distance (in grid steps, 3-4 chamfer) to the nearest unknown point of the w × w
// inner region. False when the inner region is fully known (the patch has nothing to fill).
bool frontier_distance(const GridColours& g, int w, std::vector<float>& dist) {
  const int32_t n = g.n;
  constexpr float kFar = 1e9f;
  dist.assign(size_t(n) * n, kFar);
  bool any = false;
  for (int32_t j = kPatchGridMargin; j < kPatchGridMargin + w; ++j)
    for (int32_t i = kPatchGridMargin; i < kPatchGridMargin + w; ++i)
      if (!g.known(i, j)) dist[size_t(j) * n + i] = 0.f, any = true;
  if (!any) return false;
  auto relax = [&](int32_t i, int32_t j, int32_t di, int32_t dj, float cost) {
    const int32_t a = i + di, b = j + dj;
    if (a < 0 || b < 0 || a >= n || b >= n) return;
    float& d = dist[size_t(j) * n + i];
    d = std::min(d, dist[size_t(b) * n + a] + cost);
  };
  for (int32_t j = 0; j < n; ++j)
    for (int32_t i = 0; i < n; ++i) {
      relax(i, j, -1, 0, 1.f), relax(i, j, 0, -1, 1.f), relax(i, j, -1, -1, 1.4142f), relax(i, j, 1, -1, 1.4142f);
    }
  for (int32_t j = n - 1; j >= 0; --j)
    for (int32_t i = n - 1; i >= 0; --i) {
      relax(i, j, 1, 0, 1.f), relax(i, j, 0, 1, 1.f), relax(i, j, 1, 1, 1.4142f), relax(i, j, -1, 1, 1.4142f);
    }
  return true;
}

// Whether a patch pastes onto sample s (u, v within its w × w inner region, not only its margin).
bool inner_covered(const PatchCoverage& cov, int32_t s, int w) {
  for (int64_t e = cov.sample_start[s]; e < cov.sample_start[size_t(s) + 1]; ++e) {
    const float u = cov.sample_uv[2 * e], v = cov.sample_uv[2 * e + 1];
    if (u >= kPatchGridMargin && u <= kPatchGridMargin + w - 1 && v >= kPatchGridMargin && v <= kPatchGridMargin + w - 1)
      return true;
  }
  return false;
}

// Representative-pixel features place a match to within a few pixels; overlapping patches a pixel or
// two apart cross-fade into blur (and seams). The match moves to the origin within ±kRefineRadius with
// the smallest mean colour difference over the grid points in `use` (the known ones; near the frontier
// when sampling). Ties keep the match itself.
constexpr int kRefineRadius = 2;
int32_t refine_origin(const GridColours& g, const std::vector<uint8_t>& use, const PatchIndex& index,
                      const ExemplarSample& s, bool tileable, int32_t id) {
  const auto o = index.origin(id);
  double best = std::numeric_limits<double>::infinity();
  int32_t best_id = id;
  for (int dy = -kRefineRadius; dy <= kRefineRadius; ++dy)
    for (int dx = -kRefineRadius; dx <= kRefineRadius; ++dx) {
      const int32_t ox = o[0] + dx, oy = o[1] + dy;
      if (ox < 0 || oy < 0 || ox >= index.origins_x || oy >= index.origins_y) continue;
      double sum = 0;
      int64_t count = 0;
      for (int32_t j = 0; j < g.n; ++j)
        for (int32_t i = 0; i < g.n; ++i) {
          if (!use[size_t(j) * g.n + size_t(i)]) continue;
          int32_t x = ox + i - kPatchGridMargin, y = oy + j - kPatchGridMargin;
          if (tileable) {
            x = ((x % s.width) + s.width) % s.width, y = ((y % s.height) + s.height) % s.height;
          } else if (x < 0 || y < 0 || x >= s.width || y >= s.height) {
            continue;
          }
          const float* px = s.pixels + (size_t(y) * size_t(s.width) + size_t(x)) * size_t(g.C);
          const float* q = g.at(i, j);
          for (int c = 0; c < g.C; ++c) sum += double(px[c] - q[c]) * double(px[c] - q[c]);
          ++count;
        }
      if (count == 0) continue;
      const double mean = sum / double(count);
      if (mean < best || (mean == best && dx == 0 && dy == 0)) best = mean, best_id = oy * index.origins_x + ox;
    }
  return best_id;
}

// Patches in order of growth from a seeded start: Dijkstra over patches that share samples, edges
// weighted by the distance between centres, so the synthesized region grows as one compact blob and
// each new patch meets it on one side (in id order or breadth first, patches around the start are
// placed before the gaps between them, and the gaps are then constrained on several sides at once).
// Other components follow from a seeded start each.
std::vector<int32_t> patch_order(const GridPatches& g, const PatchCoverage& cov, int32_t num_samples, uint64_t seed) {
  const int32_t np = g.count, n = g.size, c = n / 2;
  std::vector<std::vector<int32_t>> adj(static_cast<size_t>(np));
  for (int32_t s = 0; s < num_samples; ++s)
    for (int64_t a = cov.sample_start[s]; a < cov.sample_start[size_t(s) + 1]; ++a)
      for (int64_t b = a + 1; b < cov.sample_start[size_t(s) + 1]; ++b) {
        adj[cov.sample_patch[a]].push_back(cov.sample_patch[b]);
        adj[cov.sample_patch[b]].push_back(cov.sample_patch[a]);
      }
  for (auto& list : adj) {
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
  }
  auto centre = [&](int32_t p) { return v3(&g.positions[3 * ((size_t(p) * n + size_t(c)) * n + size_t(c))]); };
  std::vector<int32_t> starts(static_cast<size_t>(np));
  for (int32_t p = 0; p < np; ++p) starts[p] = p;
  Rng rng(seed, 11);
  for (int32_t p = np - 1; p > 0; --p) std::swap(starts[p], starts[rng.below(uint32_t(p + 1))]);
  std::vector<double> dist(static_cast<size_t>(np), std::numeric_limits<double>::infinity());
  std::vector<uint8_t> done(static_cast<size_t>(np), 0);
  std::vector<int32_t> order;
  order.reserve(size_t(np));
  using Item = std::pair<double, int32_t>;  // ties by patch id: deterministic
  for (int32_t start : starts) {
    if (done[start]) continue;
    std::priority_queue<Item, std::vector<Item>, std::greater<Item>> heap;
    dist[start] = 0;
    heap.push({0.0, start});
    while (!heap.empty()) {
      const auto [d, p] = heap.top();
      heap.pop();
      if (done[p] || d > dist[p]) continue;
      done[p] = 1;
      order.push_back(p);
      for (int32_t q : adj[p]) {
        const double nd = d + norm(centre(q) - centre(p));
        if (!done[q] && nd < dist[q]) dist[q] = nd, heap.push({nd, q});
      }
    }
  }
  return order;
}

// Samples no patch reached (a strip along boundaries, next to singularities) continue the nearest reached
// sample: its exemplar coordinate plus their offset in its local frame, in steps (vector_field_patches.md,
// "Centres"). Returns how many were filled; those with no reached sample within 64 steps stay as they are.
int64_t fill_unreached(const PatchField& field, const PatchSamples& samples, const ExemplarReader& reader,
                       PatchSynthResult& r, const std::atomic<bool>* cancel) {
  const int32_t count = samples.count;
  const double cell = 2 * field.spacing * kMinGridScale;
  std::vector<std::pair<uint64_t, int32_t>> table;
  // Rings reach 32 cells out: those neighbours must fit the key too.
  auto cell_of = [&](V3 p, int64_t c[3]) { return spatial_cell(p, cell, c, 80); };
  auto key = spatial_cell_key;
  std::vector<int32_t> missing;
  for (int32_t s = 0; s < count; ++s) {
    int64_t c[3];
    if (r.source[2 * size_t(s)] < 0) missing.push_back(s);
    else if (cell_of(v3(samples.positions + 3 * size_t(s)), c)) table.push_back({key(c[0], c[1], c[2]), s});
  }
  if (missing.empty() || table.empty()) return 0;
  std::sort(table.begin(), table.end());
  std::atomic<int64_t> filled{0};
  const int C = r.channels;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, missing.size(), 256), [&](const tbb::blocked_range<size_t>& range) {
    throw_if_cancelled(cancel);
    for (size_t m = range.begin(); m < range.end(); ++m) {
      const int32_t s = missing[m];
      const V3 x = v3(samples.positions + 3 * size_t(s));
      int64_t c[3];
      if (!cell_of(x, c)) continue;
      int32_t best = -1;
      double best_d = std::numeric_limits<double>::infinity();
      // Rings of cells outwards until the nearest found one cannot be beaten.
      for (int64_t ring = 0; ring <= 32 && (best < 0 || best_d > (ring - 1) * cell); ++ring)
        for (int64_t dx = -ring; dx <= ring; ++dx)
          for (int64_t dy = -ring; dy <= ring; ++dy)
            for (int64_t dz = -ring; dz <= ring; ++dz) {
              if (std::max({std::abs(dx), std::abs(dy), std::abs(dz)}) != ring) continue;
              const uint64_t k = key(c[0] + dx, c[1] + dy, c[2] + dz);
              for (auto it = std::lower_bound(table.begin(), table.end(), std::make_pair(k, int32_t(-1)));
                   it != table.end() && it->first == k; ++it) {
                const double d = norm(v3(samples.positions + 3 * size_t(it->second)) - x);
                if (d < best_d || (d == best_d && it->second < best)) best_d = d, best = it->second;
              }
            }
      if (best < 0) continue;
      // The reached sample's frame: up from the field, right = up × normal, step h.
      const int32_t t = samples.triangle[best];
      const double b1 = samples.barycentric[2 * size_t(best)], b2 = samples.barycentric[2 * size_t(best) + 1];
      const V3* cf = &field.corner_field[3 * size_t(t)];
      const V3 up = normalized_or(cf[0] * (1 - b1 - b2) + cf[1] * b1 + cf[2] * b2, V3{});
      if (norm(up) == 0) continue;
      const V3 right = cross(up, field.walk.tris[t].normal);
      const int32_t* tv = &field.triangles[3 * size_t(t)];
      const double h = field.spacing * ((1 - b1 - b2) * field.scale[tv[0]] + b1 * field.scale[tv[1]] + b2 * field.scale[tv[2]]);
      const V3 d = x - v3(samples.positions + 3 * size_t(best));
      const double sx = r.source[2 * size_t(best)] + dot(d, right) / h, sy = r.source[2 * size_t(best) + 1] + dot(d, up) / h;
      reader.read(sx, sy, &r.colour[size_t(s) * C]);
      r.source[2 * size_t(s)] = float(sx), r.source[2 * size_t(s) + 1] = float(sy);
      ++filled;
    }
  });
  return filled.load();
}

void validate(const GridPatches& g, const PatchCoverage& cov, int32_t num_samples, const ExemplarIndex& ix,
              const ExemplarSample& s, const PatchSynthParams& p) {
  if (g.size != ix.patch_size + 2 * kPatchGridMargin)
    throw std::invalid_argument("patch synthesis: grid patches have " + std::to_string(g.size) +
                                " points a side; the exemplar's patch size " + std::to_string(ix.patch_size) +
                                " needs " + std::to_string(ix.patch_size + 2 * kPatchGridMargin));
  if (cov.patch_start.size() != size_t(g.count) + 1 || cov.sample_start.size() != size_t(num_samples) + 1)
    throw std::invalid_argument("patch synthesis: coverage does not match the patches or samples");
  if (!s.pixels || s.width != ix.width || s.height != ix.height || s.channels != ix.channels)
    throw std::invalid_argument("patch synthesis: the sample is not the one the exemplar index was built from");
  if (!ix.full) throw std::invalid_argument("patch synthesis: the exemplar has no full-patch index");
  if (p.boundary_width < 1 || p.boundary_width > ix.patch_size / 2)
    throw std::invalid_argument("patch synthesis: boundary width must be 1.." + std::to_string(ix.patch_size / 2) +
                                ", got " + std::to_string(p.boundary_width));
  if (!(p.tolerance >= 1) || !std::isfinite(p.tolerance)) throw std::invalid_argument("patch synthesis: tolerance must be >= 1");
  if (p.candidates < 1 || p.candidates > 256) throw std::invalid_argument("patch synthesis: candidates must be 1..256");
  if (p.iterations < 1 || p.iterations > 50) throw std::invalid_argument("patch synthesis: iterations must be 1..50");
  if (!(p.robust_exponent > 0 && p.robust_exponent <= 2))
    throw std::invalid_argument("patch synthesis: robust_exponent must be in (0, 2]");
}

}  // namespace

PatchSynthResult synthesize_patches(const GridPatches& g, const PatchCoverage& cov, int32_t num_samples,
                                    const ExemplarIndex& ix, const ExemplarSample& sample,
                                    const PatchSynthParams& p) {
  validate(g, cov, num_samples, ix, sample, p);
  const auto t0 = std::chrono::steady_clock::now();
  const int C = sample.channels, w = ix.patch_size, n = g.size;
  const int32_t np = g.count;
  const ExemplarReader reader(sample, ix.tileable);
  PatchSynthResult out;
  out.channels = C;
  out.colour.assign(size_t(num_samples) * C, 0.f);
  out.source.assign(size_t(num_samples) * 2, -1.f);
  out.origin.assign(size_t(np) * 2, 0);
  out.stats.patches = np;
  std::vector<uint8_t> settled(static_cast<size_t>(num_samples), 0);
  auto report = [&](float f) {
    if (p.progress) p.progress->store(f, std::memory_order_relaxed);
  };
  const double inner_lo = kPatchGridMargin, inner_hi = kPatchGridMargin + w - 1;
  const double band = p.boundary_width;

  // Patch sampling: each patch fills the samples still unsettled; it is matched on the settled cells
  // within the boundary zone of that frontier and cross-faded into them over W_E.
  const PatchIndex& match_index = *ix.full;
  const bool from_initial = p.mode == PatchMode::kOptimisation && p.initial_source;
  if (from_initial) {
    std::fill(out.origin.begin(), out.origin.end(), -1);  // matched in the first M-step
    for (int32_t s = 0; s < num_samples; ++s) {
      const float sx = p.initial_source[2 * size_t(s)], sy = p.initial_source[2 * size_t(s) + 1];
      if (!(sx >= 0 && sy >= 0) || !std::isfinite(sx) || !std::isfinite(sy)) continue;
      reader.read(sx, sy, &out.colour[size_t(s) * C]);
      out.source[2 * size_t(s)] = sx, out.source[2 * size_t(s) + 1] = sy;
      settled[s] = 1;
    }
  }
  const std::vector<int32_t> order = from_initial ? std::vector<int32_t>() : patch_order(g, cov, num_samples, p.seed);
  Rng rng(p.seed, 7);
  GridColours grid(n, C);
  std::vector<float> raw, window, reduced, feature, colour(static_cast<size_t>(C)), frontier;
  std::vector<uint8_t> valid, use;
  for (size_t k = 0; k < order.size(); ++k) {
    if ((k & 15) == 0) {
      throw_if_cancelled(p.cancel);
      report(float(k) / float(order.size()) * (p.mode == PatchMode::kSampling ? 1.f : 0.3f));
    }
    const int32_t pid = order[k];
    out.origin[2 * size_t(pid)] = out.origin[2 * size_t(pid) + 1] = -1;
    if (cov.patch_start[pid] == cov.patch_start[size_t(pid) + 1]) continue;  // covers no sample
    grid.splat(cov, pid, out.colour, settled);
    if (!frontier_distance(grid, w, frontier)) continue;  // nothing left to fill: the patch is not used
    auto near_frontier = [&]() {  // only the boundary zone of the frontier is matched
      bool any = false;
      for (size_t c = 0; c < valid.size(); ++c) {
        const int32_t ci = match_index.cells[c][0] + kPatchGridMargin, cj = match_index.cells[c][1] + kPatchGridMargin;
        if (frontier[size_t(cj) * n + size_t(ci)] > band + kPatchCellOffset) valid[c] = 0;
        any = any || valid[c];
      }
      return any;
    };
    patch_query(grid, match_index, ix.appearance.space, raw, valid, window);
    if (!near_frontier()) {
      patch_query(grid, match_index, ix.appearance.space, raw, valid, window, kSparseWindowKnownFraction);
      near_frontier();
    }
    int32_t id;
    const bool matched = std::find(valid.begin(), valid.end(), 1) != valid.end();
    if (!matched) {
      id = int32_t(rng.below(uint32_t(match_index.count())));
      ++out.stats.random_patches;
    } else {
      const auto ranked = ranked_candidates(match_index, ix.appearance, raw, valid, p.candidates, p.exhaustive, reduced, feature);
      const double limit = ranked.front().first * p.tolerance + 1e-12;
      size_t within = 0;
      while (within < ranked.size() && ranked[within].first <= limit) ++within;
      id = ranked[rng.below(uint32_t(within))].second;
    }
    if (matched) {
      use.assign(size_t(n) * n, 0);
      for (size_t g = 0; g < use.size(); ++g)
        use[g] = grid.weight[g] >= kKnownWeight && frontier[g] <= band + kPatchCellOffset;
      id = refine_origin(grid, use, match_index, sample, ix.tileable, id);
    }
    const auto o = match_index.origin(id);
    out.origin[2 * size_t(pid)] = o[0], out.origin[2 * size_t(pid) + 1] = o[1];
    for (int64_t e = cov.patch_start[pid]; e < cov.patch_start[size_t(pid) + 1]; ++e) {
      const double u = cov.patch_uv[2 * e], v = cov.patch_uv[2 * e + 1];
      if (u < inner_lo || u > inner_hi || v < inner_lo || v > inner_hi) continue;
      const int32_t s = cov.patch_sample[e];
      float alpha = 1.f;
      if (settled[s]) {
        const int32_t i0 = std::min(int32_t(u), n - 2), j0 = std::min(int32_t(v), n - 2);
        const float au = float(u) - float(i0), av = float(v) - float(j0);
        const float d = (1 - au) * (1 - av) * frontier[size_t(j0) * n + i0] + au * (1 - av) * frontier[size_t(j0) * n + i0 + 1] +
                        (1 - au) * av * frontier[size_t(j0 + 1) * n + i0] + au * av * frontier[size_t(j0 + 1) * n + i0 + 1];
        alpha = std::clamp(1.f - d / float(band), 0.f, 1.f);
        if (alpha <= 0.f) continue;
      }
      const double sx = o[0] + (u - kPatchGridMargin) + 0.5, sy = o[1] + (v - kPatchGridMargin) + 0.5;
      reader.read(sx, sy, colour.data());
      float* dst = &out.colour[size_t(s) * C];
      for (int c = 0; c < C; ++c) dst[c] += alpha * (colour[c] - dst[c]);
      if (alpha >= 0.5f) out.source[2 * size_t(s)] = float(sx), out.source[2 * size_t(s) + 1] = float(sy);
      settled[s] = 1;
    }
  }
  out.stats.seconds_sampling = seconds_since(t0);

  if (p.mode == PatchMode::kOptimisation) {
    const auto t1 = std::chrono::steady_clock::now();
    const PatchIndex& full = *ix.full;
    const double eps2 = 1e-6 * double(full.raw_dims);
    std::vector<int32_t> match(static_cast<size_t>(np), -1);
    std::vector<double> dist2(static_cast<size_t>(np), 0.0);
    for (int it = 0; it < p.iterations; ++it) {
      throw_if_cancelled(p.cancel);
      // M-step: every patch against the full index, from the current colours (in parallel: reads only).
      std::vector<int32_t> next(static_cast<size_t>(np), -1);
      tbb::parallel_for(tbb::blocked_range<int32_t>(0, np, 8), [&](const tbb::blocked_range<int32_t>& r) {
        throw_if_cancelled(p.cancel);
        GridColours gc(n, C);
        std::vector<float> qraw, qwin, qred, qfeat;
        std::vector<uint8_t> qvalid, quse;
        std::vector<int32_t> qorigins;
        for (int32_t q = r.begin(); q < r.end(); ++q) {
          gc.splat(cov, q, out.colour, settled);
          patch_query(gc, full, ix.appearance.space, qraw, qvalid, qwin);
          if (std::find(qvalid.begin(), qvalid.end(), 1) == qvalid.end()) continue;
          auto ranked = ranked_candidates(full, ix.appearance, qraw, qvalid, p.candidates, false, qred, qfeat);
          coherent_candidates(cov, q, out.source, full, qorigins);
          for (const int32_t id : qorigins)
            ranked.push_back({masked_distance(full, ix.appearance, qraw, qvalid, id, qfeat), id});
          std::sort(ranked.begin(), ranked.end());
          quse.assign(size_t(n) * n, 0);
          for (size_t g = 0; g < quse.size(); ++g) quse[g] = gc.weight[g] >= kKnownWeight;
          next[q] = refine_origin(gc, quse, full, sample, ix.tileable, ranked.front().second);
          dist2[q] = ranked.front().first;
        }
      });
      int64_t changed = 0;
      double energy = 0;
      for (int32_t q = 0; q < np; ++q) {
        if (next[q] < 0) next[q] = match[q] >= 0 ? match[q] : out.origin[2 * size_t(q) + 1] * full.origins_x + out.origin[2 * size_t(q)];
        changed += next[q] != match[q];
        energy += std::pow(dist2[q] + eps2, p.robust_exponent / 2);  // ω d² with ω = (d² + ε²)^((r-2)/2)
      }
      match.swap(next);
      out.stats.energy.push_back(energy);
      out.stats.changed.push_back(double(changed) / std::max(1, np));
      const bool last = it + 1 == p.iterations || (it > 0 && out.stats.changed.back() < kStopChanged);
      // E-step: per sample, a discrete vote among its patches' proposals (or, !discrete, their weighted
      // mean; a gather in patch order).
      tbb::parallel_for(tbb::blocked_range<int32_t>(0, num_samples, 4096), [&](const tbb::blocked_range<int32_t>& r) {
        std::vector<double> acc(static_cast<size_t>(C));
        std::vector<float> prop(static_cast<size_t>(C)), best(static_cast<size_t>(C));
        for (int32_t s = r.begin(); s < r.end(); ++s) {
          std::fill(acc.begin(), acc.end(), 0.0);
          double wsum = 0;
          for (int64_t e = cov.sample_start[s]; e < cov.sample_start[size_t(s) + 1]; ++e) {
            const int32_t q = cov.sample_patch[e];
            const double u = cov.sample_uv[2 * e], v = cov.sample_uv[2 * e + 1];
            if (u < inner_lo || u > inner_hi || v < inner_lo || v > inner_hi || match[q] < 0) continue;
            const auto o = full.origin(match[q]);
            reader.read(o[0] + (u - kPatchGridMargin) + 0.5, o[1] + (v - kPatchGridMargin) + 0.5, prop.data());
            const double omega = std::pow(dist2[q] + eps2, (p.robust_exponent - 2) / 2);
            for (int c = 0; c < C; ++c) acc[c] += omega * prop[c];
            wsum += omega;
          }
          if (wsum <= 0) continue;
          float* dst = &out.colour[size_t(s) * C];
          if (!last && !p.discrete) {
            for (int c = 0; c < C; ++c) dst[c] = float(acc[c] / wsum);
            continue;
          }
          // Discrete vote (see PatchVote).
          double best_d = std::numeric_limits<double>::infinity();
          for (int64_t e = cov.sample_start[s]; e < cov.sample_start[size_t(s) + 1]; ++e) {
            const int32_t q = cov.sample_patch[e];
            const double u = cov.sample_uv[2 * e], v = cov.sample_uv[2 * e + 1];
            if (u < inner_lo || u > inner_hi || v < inner_lo || v > inner_hi || match[q] < 0) continue;
            const auto o = full.origin(match[q]);
            const double sx = o[0] + (u - kPatchGridMargin) + 0.5, sy = o[1] + (v - kPatchGridMargin) + 0.5;
            reader.read(sx, sy, prop.data());
            double d = 0;
            if (p.vote == PatchVote::kBestPatch) {
              const double border = std::min({u - inner_lo, inner_hi - u, v - inner_lo, inner_hi - v});
              d = -std::pow(dist2[q] + eps2, (p.robust_exponent - 2) / 2) * std::clamp(border / band, 0.05, 1.0);
            } else {
              for (int c = 0; c < C; ++c) d += (prop[c] - acc[c] / wsum) * (prop[c] - acc[c] / wsum);
            }
            if (d < best_d) {
              best_d = d;
              std::copy(prop.begin(), prop.end(), best.begin());
              out.source[2 * size_t(s)] = float(sx), out.source[2 * size_t(s) + 1] = float(sy);
            }
          }
          std::copy(best.begin(), best.end(), dst);
        }
      });
      report(0.3f + 0.7f * float(it + 1) / float(p.iterations));
      if (last) break;
    }
    for (int32_t q = 0; q < np; ++q) {
      const auto o = full.origin(match[q]);
      out.origin[2 * size_t(q)] = o[0], out.origin[2 * size_t(q) + 1] = o[1];
    }
    out.stats.seconds_optimisation = seconds_since(t1);
  }
  for (int32_t s = 0; s < num_samples; ++s) out.stats.uncovered_samples += !settled[s];
  out.stats.seconds_total = seconds_since(t0);
  report(1.f);
  return out;
}

std::vector<PatchLevelSize> patch_level_sizes(int width, int height, int patch_size, bool tileable, PatchMode mode,
                                              int levels) {
  if (levels < 1 || levels > kMaxPatchLevels)
    throw std::invalid_argument("patch synthesis: levels must be 1.." + std::to_string(kMaxPatchLevels));
  std::vector<PatchLevelSize> plan{{width, height, patch_size}};
  if (mode != PatchMode::kOptimisation) return plan;
  // A coarser level while the halved sample still holds fit_patch_size's smallest exemplar (sides of 16).
  while (int(plan.size()) < levels && std::min(plan.back().width, plan.back().height) / 2 >= 2 * kMinPatchSize) {
    const PatchLevelSize& finer = plan.back();
    const int w = finer.width / 2, h = finer.height / 2;
    plan.push_back({w, h, fit_patch_size(w, h, finer.patch_size, tileable)});
  }
  return plan;
}

SurfacePatchResult synthesize_patches_on_surface(const PatchField& field, const PatchSamples& samples,
                                                 const ExemplarIndex& index, const ExemplarSample& sample,
                                                 const SurfacePatchParams& params) {
  if (!(params.centre_spacing > 0 && params.centre_spacing <= 1))
    throw std::invalid_argument("patch synthesis: centre_spacing must be in (0, 1]");
  const std::atomic<bool>* cancel = params.synth.cancel;
  SurfacePatchResult out;
  std::vector<float> initial;
  SurfacePatchParams fine = params;
  const std::vector<PatchLevelSize> plan =
      patch_level_sizes(sample.width, sample.height, index.patch_size, index.tileable, params.synth.mode, params.levels);
  if (plan.size() > 1) {
    // The level below: half the sample, twice the step; its exemplar is analysed here (a quarter of
    // the pixels: a fraction of the full analysis) and not cached.
    const auto t = std::chrono::steady_clock::now();
    std::vector<float> half;
    halve_image(sample.pixels, sample.width, sample.height, sample.channels, half);
    const ExemplarSample coarse_sample{half.data(), sample.width / 2, sample.height / 2, sample.channels};
    ExemplarParams ep;
    ep.patch_size = plan[1].patch_size;
    ep.tileable = index.tileable;
    ep.seed = index.seed;
    ep.cancel = cancel;
    const ExemplarIndex coarse_index = build_exemplar_index(coarse_sample, ep);
    PatchField coarse_field = field;
    coarse_field.spacing *= 2;
    SurfacePatchParams coarse = params;
    coarse.levels = params.levels - 1;
    coarse.synth.progress = nullptr;  // the fine level reports (a bar that went back would mislead)
    const SurfacePatchResult below = synthesize_patches_on_surface(coarse_field, samples, coarse_index, coarse_sample, coarse);
    initial.resize(below.synth.source.size());
    for (size_t k = 0; k < initial.size(); ++k) initial[k] = below.synth.source[k] >= 0 ? 2 * below.synth.source[k] : -1.f;
    fine.synth.initial_source = initial.data();
    out.levels = below.levels + 1;
    out.seconds_coarse = seconds_since(t);
  }
  const int32_t size = index.patch_size + 2 * kPatchGridMargin;
  const double spacing = params.centre_spacing * index.patch_size;
  auto t = std::chrono::steady_clock::now();
  std::vector<FacePoint> centres = choose_patch_centres(field, samples, spacing, params.synth.seed, nullptr, cancel);
  out.seconds_centres = seconds_since(t);
  t = std::chrono::steady_clock::now();
  GridPatches grids = trace_grid_patches(field, centres.data(), int32_t(centres.size()), size, cancel);
  out.seconds_trace = seconds_since(t);
  t = std::chrono::steady_clock::now();
  PatchCoverage cov = locate_samples(field, grids, samples, cancel);
  out.seconds_locate = seconds_since(t);
  int64_t uncovered = 0;
  for (int32_t s = 0; s < samples.count; ++s) uncovered += !inner_covered(cov, s, index.patch_size);
  if (uncovered > 0) {
    // Centres among the uncovered samples (near boundaries and singularities patches are cut short).
    std::vector<uint8_t> only(static_cast<size_t>(samples.count), 0);
    for (int32_t s = 0; s < samples.count; ++s) only[s] = !inner_covered(cov, s, index.patch_size);
    t = std::chrono::steady_clock::now();
    const std::vector<FacePoint> extra =
        choose_patch_centres(field, samples, spacing * 0.75, hash_combine(params.synth.seed, 1), only.data(), cancel);
    out.seconds_centres += seconds_since(t);
    if (!extra.empty()) {
      out.extra_patches = int32_t(extra.size());
      const int32_t first = grids.count;
      t = std::chrono::steady_clock::now();
      append_grid_patches(grids, trace_grid_patches(field, extra.data(), int32_t(extra.size()), size, cancel));
      out.seconds_trace += seconds_since(t);
      t = std::chrono::steady_clock::now();
      cov = merge_coverage(cov, locate_samples(field, grids, samples, cancel, first));
      out.seconds_locate += seconds_since(t);
    }
  }
  out.patches = grids.count;
  out.invalid_grid_points = grids.invalid_points;
  out.coverage_entries = int64_t(cov.sample_patch.size());
  out.synth = synthesize_patches(grids, cov, samples.count, index, sample, fine.synth);
  const ExemplarReader reader(sample, index.tileable);
  out.extrapolated_samples = fill_unreached(field, samples, reader, out.synth, cancel);
  return out;
}

}  // namespace texsynth
