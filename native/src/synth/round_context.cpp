// SPDX-License-Identifier: GPL-3.0-or-later
// The direction-invariant half of round-neighbourhood synthesis: surface points per level, parents,
// round rings, coarsest-level ordering neighbours (see round_synth.hpp).
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <string>

#include "round_internal.hpp"
#include "texsynth/common/errors.hpp"
#include "texsynth/mesh/vec_math.hpp"
#include "texsynth/surface/texel_samples.hpp"
#include "texsynth/synth/round_synth.hpp"

namespace texsynth {
namespace {

using round_detail::Progress;
using round_detail::seconds_since;

std::atomic<int64_t> g_ring_builds{0};

// Ordering neighbourhood of a coarsest-level point: points within 2·r
// (docs/algorithms/round_neighbourhoods.md, "Order"), capped at the nearest 48 so a sample magnified far
// beyond the texel spacing cannot blow up the lists (the order only needs "how much around me is done", not
// every point).
constexpr int kOrderNeighbours = 48;
// Gutter texels mapped to their nearest covered texel for bilinear reads: 2 reaches the diagonal
// corner of a bilinear footprint at an island edge.
constexpr int32_t kReadGutter = 2;
// Parents are searched within ±2 coarse texels of the containing one (tiny islands: none).
constexpr int kParentSearch = 2;

void validate(const RoundMeshInput& m, const RoundContextParams& p) {
  if (p.target != RoundTarget::kImage && p.target != RoundTarget::kVertices)
    throw std::invalid_argument("round synthesis: unknown target");
  if (p.levels < 1 || p.levels > kRoundMaxLevels)
    throw std::invalid_argument("round synthesis: levels must be 1.." + std::to_string(kRoundMaxLevels) + ", got " +
                                std::to_string(p.levels));
  if (p.coarse_rings < 1 || p.coarse_rings > kMaxRings)
    throw std::invalid_argument("round synthesis: coarse_rings must be 1.." + std::to_string(kMaxRings) + ", got " +
                                std::to_string(p.coarse_rings));
  if (p.fine_rings < 1 || p.fine_rings > kMaxRings)
    throw std::invalid_argument("round synthesis: fine_rings must be 1.." + std::to_string(kMaxRings) + ", got " +
                                std::to_string(p.fine_rings));
  if (!std::isfinite(p.facing_limit_degrees) || p.facing_limit_degrees <= 0 || p.facing_limit_degrees > 180)
    throw std::invalid_argument("round synthesis: facing_limit_degrees must be in (0, 180]");
  if (!(p.max_overlap_fraction >= 0 && p.max_overlap_fraction <= 1))
    throw std::invalid_argument("round synthesis: max_overlap_fraction must be in [0, 1]");
  if (!std::isfinite(p.texels_per_unit) || p.texels_per_unit <= 0 || p.texels_per_unit > 1e12)
    throw std::invalid_argument("round synthesis: texels_per_unit must be finite and in (0, 1e12]");
  if (!(p.max_megabytes > 0)) throw std::invalid_argument("round synthesis: max_megabytes must be > 0");
  if (m.num_vertices < 0 || m.num_triangles < 0)
    throw std::invalid_argument("round synthesis: negative vertex or triangle count");
  if (m.num_triangles < 1) throw std::invalid_argument("round synthesis: the mesh has no triangles");
  if (!m.positions || !m.triangles) throw std::invalid_argument("round synthesis: missing positions or triangles");
  if (p.target == RoundTarget::kImage) {
    if (!m.corner_uvs) throw std::invalid_argument("round synthesis: the image target needs corner UVs");
    if (p.width < 1 || p.height < 1)
      throw std::invalid_argument("round synthesis: target size must be at least 1 x 1, got " +
                                  std::to_string(p.width) + " x " + std::to_string(p.height));
    if (p.width > kMaxTexelImageSide || p.height > kMaxTexelImageSide)
      throw std::invalid_argument("round synthesis: target sides are limited to " +
                                  std::to_string(kMaxTexelImageSide) + " texels");
    if ((p.width >> (p.levels - 1)) < 1 || (p.height >> (p.levels - 1)) < 1)
      throw std::invalid_argument("round synthesis: a " + std::to_string(p.width) + " x " + std::to_string(p.height) +
                                  " target is too small for " + std::to_string(p.levels) + " levels");
    if (p.margin < 0 || p.margin > kMaxMarginTexels)
      throw std::invalid_argument("round synthesis: margin must be in 0.." + std::to_string(kMaxMarginTexels));
    for (int64_t i = 0; i < int64_t(m.num_triangles) * 6; ++i)
      if (!std::isfinite(m.corner_uvs[i]))
        throw std::invalid_argument("round synthesis: UV of triangle " + std::to_string(i / 6) + " is NaN or infinite");
  }
  for (int64_t i = 0; i < int64_t(m.num_vertices) * 3; ++i)
    if (!std::isfinite(m.positions[i]))
      throw std::invalid_argument("round synthesis: position of vertex " + std::to_string(i / 3) +
                                  " is NaN or infinite");
  for (int64_t i = 0; i < int64_t(m.num_triangles) * 3; ++i)
    if (m.triangles[i] < 0 || m.triangles[i] >= m.num_vertices)
      throw std::invalid_argument("round synthesis: triangle " + std::to_string(i / 3) + " references vertex " +
                                  std::to_string(m.triangles[i]) + " (mesh has " + std::to_string(m.num_vertices) +
                                  " vertices)");
  if (p.scale_multiplier)
    for (int32_t v = 0; v < m.num_vertices; ++v)
      if (!std::isfinite(p.scale_multiplier[v]) || p.scale_multiplier[v] <= 0.f)
        throw std::invalid_argument("round synthesis: scale_multiplier of vertex " + std::to_string(v) +
                                    " must be finite and > 0");
}

std::string megabytes(int64_t bytes) { return std::to_string(std::llround(double(bytes) / 1e6)); }

[[noreturn]] void refuse_memory(int64_t bytes, double limit, const std::string& what) {
  std::ostringstream msg;
  msg << "round synthesis: " << what << " needs about " << megabytes(bytes) << " MB (limit " << limit
      << " MB); use a smaller target, fewer levels or rings";
  throw std::invalid_argument(msg.str());
}

// Scale multiplier interpolated at a point (1 without a field).
float point_multiplier(const RoundMeshInput& m, const float* mult, int32_t t, float b1, float b2) {
  if (!mult) return 1.f;
  const int32_t* c = m.triangles + 3 * size_t(t);
  return (1.f - b1 - b2) * mult[c[0]] + b1 * mult[c[1]] + b2 * mult[c[2]];
}

void set_radius(RoundLevel& L, const RoundMeshInput& m, const RoundContextParams& p) {
  const double base = std::ldexp(1.0, L.level) / p.texels_per_unit;
  L.radius.resize(size_t(L.num_points));
  for (int32_t i = 0; i < L.num_points; ++i) {
    const float mult = point_multiplier(m, p.scale_multiplier, L.triangle[i], L.barycentric[2 * size_t(i)],
                                        L.barycentric[2 * size_t(i) + 1]);
    L.radius[i] = float(base / double(mult));
  }
  for (int32_t i = 0; i < L.num_points; ++i)
    if (!std::isfinite(L.radius[i]) || L.radius[i] <= 0.f)
      throw std::invalid_argument("round synthesis: texels_per_unit × scale_multiplier gives a radius that is not "
                                  "finite and > 0 at level " + std::to_string(L.level));
}

// The texels of one level's UV grid (texel_samples.hpp); islands from the finest level's table
// (coarser grids drop more sliver triangles, which could split an island differently).
void sample_level(RoundSynthesisContext& ctx, RoundLevel& L, const RoundMeshInput& m, double max_overlap_fraction,
                  const std::atomic<bool>* cancel) {
  TexelSampleInput in;
  in.positions = m.positions;
  in.num_vertices = m.num_vertices;
  in.triangles = m.triangles;
  in.num_triangles = m.num_triangles;
  in.corner_uvs = m.corner_uvs;
  in.width = L.width;
  in.height = L.height;
  in.margin = kReadGutter;
  TexelSamples s = sample_texels(in, cancel);
  // Judged at the finest level only: coarser grids merge texels, so a fold's share grows there.
  if (L.level == 0 && double(s.num_overlapping_texels) > max_overlap_fraction * double(s.size())) {
    char share[32];
    std::snprintf(share, sizeof share, "%.2f", 100.0 * double(s.num_overlapping_texels) / double(std::max<size_t>(s.size(), 1)));
    throw std::invalid_argument("round synthesis: the UV map overlaps itself: " +
                                std::to_string(s.num_overlapping_texels) + " texels of the " + std::to_string(L.width) +
                                " x " + std::to_string(L.height) + " grid are covered twice (" + share +
                                "% of the covered texels; at most " + std::to_string(int(100 * max_overlap_fraction + 0.5)) +
                                "% are accepted): every texel needs one surface point, so islands must not overlap");
  }
  if (L.level == 0) {
    ctx.triangle_island = s.triangle_island;
    ctx.stats.overlapping_texels = s.num_overlapping_texels;
  }
  const size_t n = s.size();
  if (n > size_t(std::numeric_limits<int32_t>::max() / 2)) throw std::invalid_argument("round synthesis: too many texels");
  L.num_points = int32_t(n);
  L.point_id.assign(s.texel.begin(), s.texel.end());
  L.triangle.assign(s.triangle.begin(), s.triangle.end());
  L.barycentric.assign(s.barycentric.begin(), s.barycentric.end());
  L.position.assign(s.position.begin(), s.position.end());
  L.island.resize(n);
  for (size_t i = 0; i < n; ++i) L.island[i] = ctx.triangle_island[L.triangle[i]];
  L.texel_point.assign(size_t(L.width) * L.height, -1);
  for (size_t i = 0; i < n; ++i) L.texel_point[L.point_id[i]] = int32_t(i);
  for (size_t g = 0; g < s.gutter_texel.size(); ++g) L.texel_point[s.gutter_texel[g]] = -2 - s.gutter_source[g];
}

bool degenerate_triangle(const RoundMeshInput& m, int32_t t) {
  const int32_t* c = m.triangles + 3 * size_t(t);
  const V3 p0 = v3(m.positions + 3 * size_t(c[0]));
  const V3 e1 = v3(m.positions + 3 * size_t(c[1])) - p0, e2 = v3(m.positions + 3 * size_t(c[2])) - p0;
  const double longest2 = std::max({dot(e1, e1), dot(e2, e2), dot(e2 - e1, e2 - e1)});
  return !(norm(cross(e1, e2)) > 1e-7 * longest2);
}

// Vertex target: every used vertex, in its lowest-index non-degenerate triangle (a zero-area start
// face has no ring), else its lowest-index triangle.
void vertex_points(RoundSynthesisContext& ctx, RoundLevel& L, const RoundMeshInput& m) {
  std::vector<int32_t> tri(size_t(m.num_vertices), -1), corner(size_t(m.num_vertices), 0);
  std::vector<uint8_t> good(size_t(m.num_vertices), 0);
  for (int32_t t = 0; t < m.num_triangles; ++t) {
    const bool ok = !degenerate_triangle(m, t);
    for (int k = 0; k < 3; ++k) {
      const int32_t v = m.triangles[3 * size_t(t) + k];
      if (tri[v] < 0 || (ok && !good[v])) tri[v] = t, corner[v] = k, good[v] = ok;
    }
  }
  ctx.vertex_point.assign(size_t(m.num_vertices), -1);
  for (int32_t v = 0; v < m.num_vertices; ++v) {
    if (tri[v] < 0) continue;
    ctx.vertex_point[v] = int32_t(L.point_id.size());
    L.point_id.push_back(v);
    L.triangle.push_back(tri[v]);
    L.barycentric.push_back(corner[v] == 1 ? 1.f : 0.f);
    L.barycentric.push_back(corner[v] == 2 ? 1.f : 0.f);
    const float* p = m.positions + 3 * size_t(v);
    L.position.insert(L.position.end(), {p[0], p[1], p[2]});
  }
  L.num_points = int32_t(L.point_id.size());
}

// Image target: the coarse texel nearest to the point's texel centre among the covered texels of
// the same island within ±kParentSearch of the containing one (ties: lowest point index).
void image_parents(RoundLevel& fine, const RoundLevel& coarse) {
  fine.parent.assign(size_t(fine.num_points), -1);
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, fine.num_points, 4096), [&](const tbb::blocked_range<int32_t>& r) {
    for (int32_t i = r.begin(); i < r.end(); ++i) {
      const int32_t x = fine.point_id[i] % fine.width, y = fine.point_id[i] / fine.width;
      const int32_t cx = x >> 1, cy = y >> 1;
      int64_t best_d = std::numeric_limits<int64_t>::max();
      int32_t best = -1;
      for (int32_t dy = -kParentSearch; dy <= kParentSearch; ++dy)
        for (int32_t dx = -kParentSearch; dx <= kParentSearch; ++dx) {
          const int32_t X = cx + dx, Y = cy + dy;
          if (X < 0 || Y < 0 || X >= coarse.width || Y >= coarse.height) continue;
          const int32_t q = coarse.texel_point[size_t(Y) * coarse.width + X];
          if (q < 0 || coarse.island[q] != fine.island[i]) continue;
          // Centres in fine half-texel units: fine (2x + 1), coarse (4X + 2).
          const int64_t ex = 4 * int64_t(X) + 2 - (2 * int64_t(x) + 1), ey = 4 * int64_t(Y) + 2 - (2 * int64_t(y) + 1);
          const int64_t d = ex * ex + ey * ey;
          if (d < best_d || (d == best_d && q < best)) best_d = d, best = q;
        }
      fine.parent[i] = best;
    }
  });
}

// Mesh edges per vertex (sorted, unique), for filling undefined directions.
void vertex_adjacency(RoundSynthesisContext& ctx, const RoundMeshInput& m) {
  std::vector<int64_t> pairs;
  pairs.reserve(6 * size_t(m.num_triangles));
  for (int32_t t = 0; t < m.num_triangles; ++t)
    for (int k = 0; k < 3; ++k) {
      const int32_t a = m.triangles[3 * size_t(t) + k], b = m.triangles[3 * size_t(t) + (k + 1) % 3];
      if (a == b) continue;
      pairs.push_back(int64_t(a) << 32 | uint32_t(b));
      pairs.push_back(int64_t(b) << 32 | uint32_t(a));
    }
  tbb::parallel_sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  ctx.vertex_adjacency_start.assign(size_t(m.num_vertices) + 1, 0);
  ctx.vertex_adjacency.resize(pairs.size());
  for (size_t i = 0; i < pairs.size(); ++i) {
    ++ctx.vertex_adjacency_start[size_t(pairs[i] >> 32) + 1];
    ctx.vertex_adjacency[i] = int32_t(pairs[i] & 0xffffffff);
  }
  for (int32_t v = 0; v < m.num_vertices; ++v) ctx.vertex_adjacency_start[v + 1] += ctx.vertex_adjacency_start[v];
}

// Point spacing on the surface against r: per triangle (image: sqrt of world area per texel of
// UV area at this level) or per vertex (mean incident edge length).
void set_density(RoundSynthesisContext& ctx, RoundLevel& L, const RoundMeshInput& m) {
  std::vector<double> spacing;
  if (ctx.target == RoundTarget::kImage) {
    spacing.resize(size_t(m.num_triangles));
    for (int32_t t = 0; t < m.num_triangles; ++t) {
      const int32_t* c = m.triangles + 3 * size_t(t);
      const V3 p0 = v3(m.positions + 3 * size_t(c[0]));
      const double a3 = norm(cross(v3(m.positions + 3 * size_t(c[1])) - p0, v3(m.positions + 3 * size_t(c[2])) - p0));
      const float* uv = m.corner_uvs + 6 * size_t(t);
      const double auv = std::fabs((double(uv[2]) - uv[0]) * (double(uv[5]) - uv[1]) -
                                   (double(uv[4]) - uv[0]) * (double(uv[3]) - uv[1])) *
                         double(L.width) * double(L.height);
      spacing[t] = auv > 0 ? std::sqrt(a3 / auv) : 0;
    }
  } else {
    spacing.resize(size_t(m.num_vertices), 0);
    for (int32_t v = 0; v < m.num_vertices; ++v) {
      double sum = 0;
      const int32_t b = ctx.vertex_adjacency_start[v], e = ctx.vertex_adjacency_start[v + 1];
      for (int32_t k = b; k < e; ++k)
        sum += norm(v3(m.positions + 3 * size_t(v)) - v3(m.positions + 3 * size_t(ctx.vertex_adjacency[k])));
      spacing[v] = e > b ? sum / (e - b) : 0;
    }
  }
  L.density.resize(size_t(L.num_points));
  for (int32_t i = 0; i < L.num_points; ++i) {
    const double sp = spacing[ctx.target == RoundTarget::kImage ? L.triangle[i] : L.point_id[i]];
    L.density[i] = sp > 0 ? float(std::min(1e6, double(L.radius[i]) / sp)) : 0.f;
  }
}

// Coarsest level: for every point p its (up to) 48 nearest points within 2·r_p (a uniform grid of
// cell 2·max r), then inverted so synthesizing q finds the points whose coverage it raises.
void order_neighbours(RoundLevel& L, const std::atomic<bool>* cancel) {
  const int32_t n = L.num_points;
  L.cover_start.assign(size_t(n) + 1, 0);
  L.cover_list.clear();
  if (n == 0) return;
  double rmax = 0;
  for (float r : L.radius) rmax = std::max(rmax, double(r));
  const double cell = 2 * rmax;
  std::array<double, 3> lo{std::numeric_limits<double>::max(), std::numeric_limits<double>::max(),
                           std::numeric_limits<double>::max()};
  for (int32_t i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], double(L.position[3 * size_t(i) + k]));
  // 21 bits per axis; a mesh wider than 2M cells folds cells together, which only costs time.
  auto cell_of = [&](int32_t i, int k) {
    const double c = std::floor((double(L.position[3 * size_t(i) + k]) - lo[k]) / cell);
    return int64_t(std::min(c, 1e15)) & 0x1fffff;  // >= 0; the cap keeps the conversion defined
  };
  auto key = [](int64_t x, int64_t y, int64_t z) { return (x << 42) | (y << 21) | z; };
  std::vector<std::pair<int64_t, int32_t>> sorted(static_cast<size_t>(n));
  for (int32_t i = 0; i < n; ++i) sorted[i] = {key(cell_of(i, 0), cell_of(i, 1), cell_of(i, 2)), i};
  tbb::parallel_sort(sorted.begin(), sorted.end());
  throw_if_cancelled(cancel);
  std::vector<int32_t> forward(size_t(n) * kOrderNeighbours, -1);
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, n, 256), [&](const tbb::blocked_range<int32_t>& r) {
    throw_if_cancelled(cancel);
    std::vector<std::pair<double, int32_t>> found;
    for (int32_t i = r.begin(); i < r.end(); ++i) {
      found.clear();
      const double reach = 2.0 * L.radius[i], reach2 = reach * reach;
      const V3 pi = v3(&L.position[3 * size_t(i)]);
      const int64_t cx = cell_of(i, 0), cy = cell_of(i, 1), cz = cell_of(i, 2);
      for (int64_t dz = -1; dz <= 1; ++dz)
        for (int64_t dy = -1; dy <= 1; ++dy)
          for (int64_t dx = -1; dx <= 1; ++dx) {
            const int64_t X = cx + dx, Y = cy + dy, Z = cz + dz;
            if (X < 0 || Y < 0 || Z < 0 || X > 0x1fffff || Y > 0x1fffff || Z > 0x1fffff) continue;
            const int64_t k = key(X, Y, Z);
            auto it = std::lower_bound(sorted.begin(), sorted.end(), std::make_pair(k, int32_t(-1)));
            for (; it != sorted.end() && it->first == k; ++it) {
              const int32_t j = it->second;
              if (j == i) continue;
              const V3 d = v3(&L.position[3 * size_t(j)]) - pi;
              const double d2 = dot(d, d);
              if (d2 < reach2) found.push_back({d2, j});
            }
          }
      const size_t keep = std::min<size_t>(found.size(), kOrderNeighbours);
      std::partial_sort(found.begin(), found.begin() + keep, found.end());
      for (size_t k = 0; k < keep; ++k) forward[size_t(i) * kOrderNeighbours + k] = found[k].second;
    }
  });
  // Invert: cover_list[q] = { p : q in forward[p] }, p ascending (counting sort).
  for (size_t k = 0; k < forward.size(); ++k)
    if (forward[k] >= 0) ++L.cover_start[size_t(forward[k]) + 1];
  for (int32_t q = 0; q < n; ++q) L.cover_start[q + 1] += L.cover_start[q];
  L.cover_list.resize(size_t(L.cover_start[n]));
  std::vector<int32_t> next(L.cover_start.begin(), L.cover_start.end() - 1);
  for (int32_t p = 0; p < n; ++p)
    for (int k = 0; k < kOrderNeighbours; ++k) {
      const int32_t q = forward[size_t(p) * kOrderNeighbours + k];
      if (q >= 0) L.cover_list[next[q]++] = p;
    }
}

// Bytes the context keeps, and the extra peak while it is built.
struct ContextMemory {
  int64_t kept = 0, transient = 0;
};

ContextMemory context_memory(const RoundSynthesisContext& ctx, const RoundMeshInput& m) {
  ContextMemory mem;
  const int64_t T = m.num_triangles, V = m.num_vertices;
  mem.kept += T * (12 + 24 + 4) + V * (4 + 4 + 4 * 6);  // triangles, UVs, islands; vertex map, adjacency
  for (const RoundLevel& L : ctx.levels) {
    const int64_t n = L.num_points;
    mem.kept += n * (4 + 4 + 8 + 12 + 4 + 4 + 4 + 4);  // point arrays
    mem.kept += int64_t(L.width) * L.height * 4;     // texel_point
    const RoundRingsMemory rm = estimate_round_rings_memory(n, T, V, L.rings);
    mem.kept += rm.result_bytes;
    mem.transient = std::max(mem.transient, rm.peak_bytes - rm.result_bytes);
    if (&L == &ctx.levels.back()) {
      mem.kept += n * (kOrderNeighbours + 1) * 4;           // cover lists (at most)
      mem.transient = std::max(mem.transient, n * (kOrderNeighbours * 4 + 16));  // forward table + sort
    }
  }
  if (ctx.target == RoundTarget::kImage)  // the finest texel_samples while it is copied
    mem.transient = std::max(mem.transient, estimate_texel_sample_bytes(ctx.width, ctx.height));
  return mem;
}

}  // namespace

RoundTemplate round_template(int rings) {
  if (rings < 1 || rings > kMaxRings)
    throw std::invalid_argument("round_template: rings must be 1.." + std::to_string(kMaxRings));
  RoundTemplate t;
  t.rings = rings;
  t.ring_start.push_back(0);
  for (int m = 1; m <= rings; ++m) {
    // Crossings with the vertical lines x = i and horizontal lines y = j, |i|, |j| <= m.
    std::vector<std::pair<double, double>> pts;
    for (int i = -m; i <= m; ++i) {
      const double h = std::sqrt(double(m * m - i * i));
      pts.push_back({double(i), h});
      if (h > 0) pts.push_back({double(i), -h});
      pts.push_back({h, double(i)});
      if (h > 0) pts.push_back({-h, double(i)});
    }
    std::vector<std::pair<double, std::pair<double, double>>> by_angle;
    for (auto& p : pts) {
      double a = std::atan2(p.second, p.first);
      if (a < 0) a += 2 * M_PI;
      if (a >= 2 * M_PI) a = 0;
      by_angle.push_back({a, p});
    }
    std::sort(by_angle.begin(), by_angle.end());
    for (size_t k = 0; k < by_angle.size(); ++k) {
      if (k > 0 && by_angle[k].first - by_angle[k - 1].first < 1e-9) continue;  // the same crossing twice
      t.angle.push_back(float(by_angle[k].first));
      t.dx.push_back(float(by_angle[k].second.first));
      t.dy.push_back(float(by_angle[k].second.second));
    }
    t.ring_start.push_back(int(t.dx.size()));
  }
  return t;
}

int64_t round_context_ring_builds() { return g_ring_builds.load(); }

RoundSynthesisContext build_round_context(const RoundMeshInput& m, const RoundContextParams& p) {
  const auto t_start = std::chrono::steady_clock::now();
  validate(m, p);
  const Progress progress(p.progress);
  progress.reset();
  throw_if_cancelled(p.cancel);
  RoundSynthesisContext ctx;
  ctx.target = p.target;
  ctx.width = p.target == RoundTarget::kImage ? p.width : 0;
  ctx.height = p.target == RoundTarget::kImage ? p.height : 0;
  ctx.margin = p.target == RoundTarget::kImage ? p.margin : 0;
  ctx.num_vertices = m.num_vertices;
  ctx.num_triangles = m.num_triangles;
  ctx.texels_per_unit = p.texels_per_unit;
  ctx.facing_limit_degrees = p.facing_limit_degrees;
  ctx.max_megabytes = p.max_megabytes;

  // Up front, before any large allocation: the finest texel samples and the output image alone.
  if (p.target == RoundTarget::kImage) {
    const int64_t floor_bytes = estimate_texel_sample_bytes(p.width, p.height) + int64_t(p.width) * p.height * (4 + 4 * 4 * 2);
    if (double(floor_bytes) > p.max_megabytes * 1e6)
      refuse_memory(floor_bytes, p.max_megabytes,
                    "a " + std::to_string(p.width) + " x " + std::to_string(p.height) + " target");
  }

  auto t0 = std::chrono::steady_clock::now();
  ctx.triangles.assign(m.triangles, m.triangles + 3 * size_t(m.num_triangles));
  ctx.levels.resize(size_t(p.levels));
  for (int l = 0; l < p.levels; ++l) {
    RoundLevel& L = ctx.levels[l];
    L.level = l;
    L.rings = l == p.levels - 1 ? p.coarse_rings : p.fine_rings;
  }
  if (p.target == RoundTarget::kImage) {
    ctx.corner_uvs.assign(m.corner_uvs, m.corner_uvs + 6 * size_t(m.num_triangles));
    for (int l = 0; l < p.levels; ++l) {
      RoundLevel& L = ctx.levels[l];
      L.width = p.width >> l;
      L.height = p.height >> l;
      sample_level(ctx, L, m, p.max_overlap_fraction, p.cancel);
      if (l == 0 && L.num_points == 0)
        throw std::invalid_argument("round synthesis: no texel centre of the " + std::to_string(p.width) + " x " +
                                    std::to_string(p.height) + " image lies inside a UV triangle");
    }
    for (int l = 0; l + 1 < p.levels; ++l) image_parents(ctx.levels[l], ctx.levels[l + 1]);
    ctx.levels.back().parent.assign(size_t(ctx.levels.back().num_points), -1);
  } else {
    vertex_points(ctx, ctx.levels[0], m);
    if (ctx.levels[0].num_points == 0) throw std::invalid_argument("round synthesis: no vertex is used by a triangle");
    for (int l = 1; l < p.levels; ++l) {
      RoundLevel& L = ctx.levels[l];
      const RoundLevel& F = ctx.levels[0];
      L.num_points = F.num_points;
      L.point_id = F.point_id;
      L.triangle = F.triangle;
      L.barycentric = F.barycentric;
      L.position = F.position;
    }
    for (int l = 0; l < p.levels; ++l) {
      RoundLevel& L = ctx.levels[l];
      L.parent.resize(size_t(L.num_points));
      if (l + 1 < p.levels) std::iota(L.parent.begin(), L.parent.end(), 0);
      else std::fill(L.parent.begin(), L.parent.end(), -1);
    }
  }
  for (RoundLevel& L : ctx.levels) set_radius(L, m, p);
  vertex_adjacency(ctx, m);
  for (RoundLevel& L : ctx.levels) set_density(ctx, L, m);
  ctx.stats.seconds_points = seconds_since(t0);
  progress.set(0.1);
  throw_if_cancelled(p.cancel);

  // Exact estimate now that the point counts are known, before the expensive part.
  const ContextMemory mem = context_memory(ctx, m);
  ctx.context_bytes = mem.kept;
  const int64_t synth_bytes = round_detail::estimate_synthesis_bytes(ctx, 256, 256, 3);
  ctx.stats.estimated_bytes = mem.kept + std::max(mem.transient, synth_bytes);
  if (double(ctx.stats.estimated_bytes) > p.max_megabytes * 1e6) {
    std::string what = std::to_string(ctx.levels[0].num_points) + " points";
    if (p.target == RoundTarget::kImage) what += " (" + std::to_string(p.width) + " x " + std::to_string(p.height) + " target)";
    what += " with " + std::to_string(p.levels) + " levels";
    refuse_memory(ctx.stats.estimated_bytes, p.max_megabytes, what);
  }

  t0 = std::chrono::steady_clock::now();
  order_neighbours(ctx.levels.back(), p.cancel);
  ctx.stats.seconds_order = seconds_since(t0);
  progress.set(0.15);

  // Rings, finest first; progress by ring entries.
  t0 = std::chrono::steady_clock::now();
  double total_entries = 0, done_entries = 0;
  for (const RoundLevel& L : ctx.levels) total_entries += double(L.num_points) * ring_entries(L.rings);
  TriangleMeshInput tm;
  tm.positions = m.positions;
  tm.num_vertices = m.num_vertices;
  tm.triangles = m.triangles;
  tm.num_triangles = m.num_triangles;
  for (RoundLevel& L : ctx.levels) {
    SurfacePoints pts;
    pts.triangle = L.triangle.data();
    pts.barycentric = L.barycentric.data();
    pts.radius = L.radius.data();
    pts.num_points = L.num_points;
    RoundRingsParams rp;
    rp.rings = L.rings;
    rp.facing_limit_degrees = p.facing_limit_degrees;
    rp.max_megabytes = p.max_megabytes;  // the whole budget was checked above
    rp.cancel = p.cancel;
    L.rings_data = build_round_rings(tm, pts, rp);
    g_ring_builds.fetch_add(1);
    ctx.stats.invalid_ring_fraction.push_back(L.rings_data.invalid_fraction());
    done_entries += double(L.num_points) * ring_entries(L.rings);
    progress.set(0.15 + 0.85 * done_entries / std::max(1.0, total_entries));
  }
  ctx.stats.seconds_rings = seconds_since(t0);
  ctx.stats.seconds_total = seconds_since(t_start);
  progress.set(1);
  return ctx;
}

}  // namespace texsynth
