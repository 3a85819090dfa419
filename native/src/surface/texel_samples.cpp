// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/surface/texel_samples.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

#include "texsynth/common/errors.hpp"
#include "texsynth/common/uninitialized_vector.hpp"
#include "texsynth/mesh/vec_math.hpp"
#include "texsynth/surface/dilate.hpp"

namespace texsynth {
namespace {

// Snapped coordinates stay within 2^52 (|UV| <= 2^20, side <= 2^16, 16 sub-texel bits), so edge
// functions (products of two differences) stay within 2^107: exact in 128 bits.
__extension__ typedef __int128 Wide;

constexpr int64_t kSub = 65536;       // sub-texel steps per texel
constexpr int64_t kHalf = kSub / 2;   // texel centre offset
constexpr int32_t kBandRows = 16;     // rows rasterised by one task

int64_t floor_div(int64_t a, int64_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }
int64_t ceil_div(int64_t a, int64_t b) { return -floor_div(-a, b); }

// One UV triangle ready for coverage tests, oriented counter-clockwise (corners 1 and 2 swapped
// when mirrored). A texel centre p is inside iff E_i(p) >= bias_i for its three edges.
struct Raster {
  int64_t x[3], y[3];   // snapped texel coordinates, kSub per texel
  int64_t bias[3];      // 0: the edge owns centres exactly on it; 1: it does not
  int32_t x0 = 0, x1 = -1, y0 = 0, y1 = -1;  // candidate texel range (empty when x1 < x0 or y1 < y0)
  bool degenerate = false;
};

std::string tri_name(int32_t t) { return "sample_texels: triangle " + std::to_string(t); }

void validate(const TexelSampleInput& in) {
  if (in.width < 1 || in.height < 1)
    throw std::invalid_argument("sample_texels: image size must be at least 1 x 1, got " + std::to_string(in.width) +
                                " x " + std::to_string(in.height));
  if (in.width > kMaxTexelImageSide || in.height > kMaxTexelImageSide)
    throw std::invalid_argument("sample_texels: image sides are limited to " + std::to_string(kMaxTexelImageSide) +
                                " texels, got " + std::to_string(in.width) + " x " + std::to_string(in.height));
  const int64_t bytes = estimate_texel_sample_bytes(in.width, in.height);
  if (bytes > kMaxTexelSampleBytes)
    throw std::invalid_argument("sample_texels: a " + std::to_string(in.width) + " x " + std::to_string(in.height) +
                                " image needs up to " + std::to_string(bytes / 1000000) + " MB of texel samples (limit " +
                                std::to_string(kMaxTexelSampleBytes / 1000000) + " MB, 8192 x 8192 texels)");
  if (in.margin < 0 || in.margin > kMaxMarginTexels)
    throw std::invalid_argument("sample_texels: margin must be in 0.." + std::to_string(kMaxMarginTexels) + ", got " +
                                std::to_string(in.margin));
  if (in.num_vertices < 0 || in.num_triangles < 0)
    throw std::invalid_argument("sample_texels: negative vertex or triangle count");
  if ((in.num_vertices > 0 && !in.positions) || (in.num_triangles > 0 && (!in.triangles || !in.corner_uvs)))
    throw std::invalid_argument("sample_texels: missing positions, triangles or corner UVs");
  for (int32_t t = 0; t < in.num_triangles; ++t) {
    for (int k = 0; k < 3; ++k) {
      const int32_t v = in.triangles[3 * size_t(t) + k];
      if (v < 0 || v >= in.num_vertices)
        throw std::invalid_argument(tri_name(t) + " references vertex " + std::to_string(v) + " (mesh has " +
                                    std::to_string(in.num_vertices) + " vertices)");
      const float* p = in.positions + 3 * size_t(v);
      if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
        throw std::invalid_argument(tri_name(t) + ": position of vertex " + std::to_string(v) + " is NaN or infinite");
      const float* uv = in.corner_uvs + 6 * size_t(t) + 2 * k;
      if (!std::isfinite(uv[0]) || !std::isfinite(uv[1]))
        throw std::invalid_argument(tri_name(t) + ": UV of corner " + std::to_string(k) + " is NaN or infinite");
      if (in.corner_normals) {
        const float* n = in.corner_normals + 9 * size_t(t) + 3 * k;
        if (!std::isfinite(n[0]) || !std::isfinite(n[1]) || !std::isfinite(n[2]))
          throw std::invalid_argument(tri_name(t) + ": normal of corner " + std::to_string(k) + " is NaN or infinite");
      }
    }
  }
  // Vertices no triangle uses (the loop above named the triangle of the others).
  for (int64_t i = 0; i < int64_t(in.num_vertices) * 3; ++i)
    if (!std::isfinite(in.positions[i]))
      throw std::invalid_argument("sample_texels: position of vertex " + std::to_string(i / 3) +
                                  " (used by no triangle) is NaN or infinite");
}

Raster setup_raster(const TexelSampleInput& in, int32_t t) {
  Raster r;
  const float* uv = in.corner_uvs + 6 * size_t(t);
  for (int k = 0; k < 3; ++k)
    if (std::fabs(uv[2 * k]) > kMaxUvMagnitude || std::fabs(uv[2 * k + 1]) > kMaxUvMagnitude) {
      r.degenerate = true;
      return r;
    }
  // float * side * 2^16 has at most 24 + 16 significant bits: exact in double, so the same
  // float always snaps to the same integer and shared corners stay shared.
  for (int k = 0; k < 3; ++k) {
    r.x[k] = std::llround(double(uv[2 * k]) * in.width * kSub);
    r.y[k] = std::llround(double(uv[2 * k + 1]) * in.height * kSub);
  }
  const Wide area2 = Wide(r.x[1] - r.x[0]) * (r.y[2] - r.y[0]) - Wide(r.x[2] - r.x[0]) * (r.y[1] - r.y[0]);
  double longest2 = 0;
  for (int k = 0; k < 3; ++k) {
    const double dx = double(r.x[(k + 1) % 3] - r.x[k]), dy = double(r.y[(k + 1) % 3] - r.y[k]);
    longest2 = std::max(longest2, dx * dx + dy * dy);
  }
  const double min_height = kMinUvTriangleHeightTexels * kSub;
  const double a2 = double(area2);
  if (area2 == 0 || a2 * a2 < min_height * min_height * longest2) {  // height = |2A| / longest edge
    r.degenerate = true;
    return r;
  }
  if (area2 < 0) std::swap(r.x[1], r.x[2]), std::swap(r.y[1], r.y[2]);
  for (int k = 0; k < 3; ++k) {
    // The edge owns the centres on it iff a point nudged by (+e, +e^2) from there is inside,
    // i.e. iff that nudge points to the interior (left) side: the same rule for every triangle,
    // so of two triangles on a shared edge (opposite directions) exactly one owns it.
    const int64_t dx = r.x[(k + 1) % 3] - r.x[k], dy = r.y[(k + 1) % 3] - r.y[k];
    r.bias[k] = (dy < 0 || (dy == 0 && dx > 0)) ? 0 : 1;
  }
  const int64_t min_x = std::min({r.x[0], r.x[1], r.x[2]}), max_x = std::max({r.x[0], r.x[1], r.x[2]});
  const int64_t min_y = std::min({r.y[0], r.y[1], r.y[2]}), max_y = std::max({r.y[0], r.y[1], r.y[2]});
  // Texels whose centre kSub * x + kHalf lies in [min, max], clamped to the image.
  r.x0 = int32_t(std::max<int64_t>(0, ceil_div(min_x - kHalf, kSub)));
  r.x1 = int32_t(std::min<int64_t>(in.width - 1, floor_div(max_x - kHalf, kSub)));
  r.y0 = int32_t(std::max<int64_t>(0, ceil_div(min_y - kHalf, kSub)));
  r.y1 = int32_t(std::min<int64_t>(in.height - 1, floor_div(max_y - kHalf, kSub)));
  return r;
}

// Claims the centres of rows [row_begin, row_end] of `r` for triangle t: the first (lowest) triangle
// keeps the texel, later ones mark it overlapping. owner and overlap hold the band's rows only.
void rasterize(const Raster& r, int32_t t, int32_t width, int32_t band_y0, int32_t row_begin, int32_t row_end,
               int32_t* owner, uint8_t* overlap, int64_t& num_overlapping) {
  Wide step[3];
  for (int k = 0; k < 3; ++k) step[k] = -Wide(r.y[(k + 1) % 3] - r.y[k]) * kSub;
  const int64_t px0 = kSub * r.x0 + kHalf;
  for (int32_t y = row_begin; y <= row_end; ++y) {
    const int64_t py = kSub * y + kHalf;
    Wide e[3];
    for (int k = 0; k < 3; ++k) {
      const int k1 = (k + 1) % 3;
      e[k] = Wide(r.x[k1] - r.x[k]) * (py - r.y[k]) - Wide(r.y[k1] - r.y[k]) * (px0 - r.x[k]) - r.bias[k];
    }
    int32_t* row_owner = owner + size_t(y - band_y0) * width;
    uint8_t* row_overlap = overlap + size_t(y - band_y0) * width;
    bool entered = false;
    for (int32_t x = r.x0; x <= r.x1; ++x) {
      if (e[0] >= 0 && e[1] >= 0 && e[2] >= 0) {
        entered = true;
        if (row_owner[x] < 0) {
          row_owner[x] = t;
        } else if (!row_overlap[x]) {
          row_overlap[x] = 1;
          ++num_overlapping;
        }
      } else if (entered) {
        break;  // convex: the row's inside run is over
      }
      e[0] += step[0], e[1] += step[1], e[2] += step[2];
    }
  }
}

// UV islands: triangles joined across a mesh edge whose two UV corners are equal on both sides.
// Union-find with the smaller root kept, then ids numbered by lowest triangle: deterministic.
int32_t compute_islands(const TexelSampleInput& in, const std::vector<Raster>& raster, std::vector<int32_t>& island,
                        const std::atomic<bool>* cancel) {
  const int32_t nt = in.num_triangles;
  // Half-edges bucketed by their lower vertex (counting sort), each bucket sorted by the upper one.
  struct HalfEdge {
    int32_t hi, tri;
    int8_t c_lo, c_hi;  // corners of this triangle at the lower and upper vertex
  };
  std::vector<int32_t> start(size_t(in.num_vertices) + 1, 0);
  auto for_each_edge = [&](auto&& f) {
    for (int32_t t = 0; t < nt; ++t) {
      if (raster[t].degenerate) continue;
      const int32_t* v = in.triangles + 3 * size_t(t);
      for (int k = 0; k < 3; ++k) {
        const int k1 = (k + 1) % 3;
        if (v[k] == v[k1]) continue;
        if (v[k] < v[k1]) f(v[k], HalfEdge{v[k1], t, int8_t(k), int8_t(k1)});
        else f(v[k1], HalfEdge{v[k], t, int8_t(k1), int8_t(k)});
      }
    }
  };
  for_each_edge([&](int32_t lo, const HalfEdge&) { ++start[lo + 1]; });
  for (int32_t v = 0; v < in.num_vertices; ++v) start[v + 1] += start[v];
  std::vector<HalfEdge> edges(static_cast<size_t>(start[in.num_vertices]));
  {
    std::vector<int32_t> next(start.begin(), start.end() - 1);
    for_each_edge([&](int32_t lo, const HalfEdge& h) { edges[next[lo]++] = h; });
  }
  throw_if_cancelled(cancel);
  std::vector<int32_t> parent(static_cast<size_t>(nt));
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int32_t a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  auto same_uv = [&](const HalfEdge& a, int8_t ca, const HalfEdge& b, int8_t cb) {
    const float* ua = in.corner_uvs + 6 * size_t(a.tri) + 2 * ca;
    const float* ub = in.corner_uvs + 6 * size_t(b.tri) + 2 * cb;
    return ua[0] == ub[0] && ua[1] == ub[1];
  };
  for (int32_t v = 0; v < in.num_vertices; ++v) {
    auto b = edges.begin() + start[v], e = edges.begin() + start[v + 1];
    std::sort(b, e, [](const HalfEdge& p, const HalfEdge& q) { return p.hi != q.hi ? p.hi < q.hi : p.tri < q.tri; });
    for (auto i = b; i != e; ++i)
      for (auto j = i + 1; j != e && j->hi == i->hi; ++j)
        if (same_uv(*i, i->c_lo, *j, j->c_lo) && same_uv(*i, i->c_hi, *j, j->c_hi)) {
          const int32_t ri = find(i->tri), rj = find(j->tri);
          if (ri != rj) parent[std::max(ri, rj)] = std::min(ri, rj);
        }
  }
  island.assign(size_t(nt), -1);
  int32_t count = 0;
  for (int32_t t = 0; t < nt; ++t) {
    if (raster[t].degenerate) continue;
    const int32_t root = find(t);  // root <= t, so its id is already set unless root == t
    island[t] = root == t ? count++ : island[root];
  }
  return count;
}

// Area-weighted vertex normals, summed in triangle order (the same doubles whatever the threads).
std::vector<V3> vertex_normals(const TexelSampleInput& in) {
  std::vector<V3> acc(size_t(in.num_vertices));
  for (int32_t t = 0; t < in.num_triangles; ++t) {
    const int32_t* v = in.triangles + 3 * size_t(t);
    const V3 p0 = v3(in.positions + 3 * size_t(v[0]));
    const V3 n = cross(v3(in.positions + 3 * size_t(v[1])) - p0, v3(in.positions + 3 * size_t(v[2])) - p0);
    for (int k = 0; k < 3; ++k) acc[v[k]] = acc[v[k]] + n;
  }
  for (V3& n : acc) n = normalized_or(n, V3{0, 0, 1}, 1e-30);
  return acc;
}

}  // namespace

int64_t estimate_texel_sample_bytes(int64_t width, int64_t height) {
  if (width < 1 || height < 1) throw std::invalid_argument("estimate_texel_sample_bytes: width and height must be >= 1");
  return width * height * kTexelSampleBytesPerTexel;
}

TexelSamples sample_texels(const TexelSampleInput& in, const std::atomic<bool>* cancel) {
  validate(in);
  throw_if_cancelled(cancel);
  const int32_t W = in.width, H = in.height, nt = in.num_triangles;
  TexelSamples out;
  out.width = W, out.height = H, out.margin = in.margin;

  std::vector<Raster> raster(static_cast<size_t>(nt));
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, nt, 4096), [&](const tbb::blocked_range<int32_t>& r) {
    throw_if_cancelled(cancel);
    for (int32_t t = r.begin(); t < r.end(); ++t) raster[t] = setup_raster(in, t);
  });
  for (const Raster& r : raster) out.num_degenerate_triangles += r.degenerate;

  // Triangles of each band of rows, ascending (a serial counting sort: cheap next to rasterising).
  const int32_t num_bands = (H + kBandRows - 1) / kBandRows;
  std::vector<int32_t> band_start(size_t(num_bands) + 1, 0), band_tris;
  auto touches = [&](const Raster& r) { return !r.degenerate && r.x0 <= r.x1 && r.y0 <= r.y1; };
  for (const Raster& r : raster)
    if (touches(r))
      for (int32_t b = r.y0 / kBandRows; b <= r.y1 / kBandRows; ++b) ++band_start[b + 1];
  for (int32_t b = 0; b < num_bands; ++b) band_start[b + 1] += band_start[b];
  band_tris.resize(size_t(band_start[num_bands]));
  {
    std::vector<int32_t> next(band_start.begin(), band_start.end() - 1);
    for (int32_t t = 0; t < nt; ++t)
      if (touches(raster[t]))
        for (int32_t b = raster[t].y0 / kBandRows; b <= raster[t].y1 / kBandRows; ++b) band_tris[next[b]++] = t;
  }
  throw_if_cancelled(cancel);

  // Per texel: the owning triangle (-1: none), later replaced by the sample index.
  UninitializedVector<int32_t> owner(size_t(W) * H);
  std::vector<int64_t> band_overlaps(size_t(num_bands), 0);
  std::vector<V3> vnormals;
  tbb::parallel_invoke(
      [&] {
        tbb::parallel_for(tbb::blocked_range<int32_t>(0, num_bands, 1), [&](const tbb::blocked_range<int32_t>& range) {
          std::vector<uint8_t> overlap;
          for (int32_t b = range.begin(); b < range.end(); ++b) {
            throw_if_cancelled(cancel);
            const int32_t y0 = b * kBandRows, y1 = std::min(H, y0 + kBandRows);
            int32_t* band_owner = owner.data() + size_t(y0) * W;
            std::fill(band_owner, band_owner + size_t(y1 - y0) * W, -1);
            overlap.assign(size_t(y1 - y0) * W, 0);
            for (int32_t i = band_start[b]; i < band_start[b + 1]; ++i) {
              const Raster& r = raster[band_tris[i]];
              rasterize(r, band_tris[i], W, y0, std::max(r.y0, y0), std::min(r.y1, y1 - 1), band_owner, overlap.data(),
                        band_overlaps[b]);
            }
          }
        });
      },
      [&] { out.num_islands = compute_islands(in, raster, out.triangle_island, cancel); },
      [&] {
        if (!in.corner_normals) vnormals = vertex_normals(in);
      });
  for (int64_t n : band_overlaps) out.num_overlapping_texels += n;
  throw_if_cancelled(cancel);

  // Samples in texel order: rows counted, offsets summed, rows filled in parallel.
  std::vector<int64_t> row_start(size_t(H) + 1, 0);
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, H, 16), [&](const tbb::blocked_range<int32_t>& r) {
    for (int32_t y = r.begin(); y < r.end(); ++y) {
      const int32_t* row = owner.data() + size_t(y) * W;
      row_start[y + 1] = std::count_if(row, row + W, [](int32_t o) { return o >= 0; });
    }
  });
  for (int32_t y = 0; y < H; ++y) row_start[y + 1] += row_start[y];
  const size_t n = size_t(row_start[H]);
  out.texel.resize(n);
  out.triangle.resize(n);
  out.barycentric.resize(2 * n);
  out.position.resize(3 * n);
  out.normal.resize(3 * n);
  out.island.resize(n);
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, H, 8), [&](const tbb::blocked_range<int32_t>& r) {
    throw_if_cancelled(cancel);
    for (int32_t y = r.begin(); y < r.end(); ++y) {
      int32_t* row = owner.data() + size_t(y) * W;
      size_t s = size_t(row_start[y]);
      for (int32_t x = 0; x < W; ++x) {
        const int32_t t = row[x];
        if (t < 0) continue;
        row[x] = int32_t(s);
        out.texel[s] = y * W + x;
        out.triangle[s] = t;
        out.island[s] = out.triangle_island[t];
        // Barycentrics from the unsnapped UVs (so they reproduce the texel centre), clamped into the
        // triangle: snapping may admit a centre up to 1/131072 texel outside it.
        const float* uv = in.corner_uvs + 6 * size_t(t);
        const double u0 = double(uv[0]) * W, v0 = double(uv[1]) * H;
        const double e1u = double(uv[2]) * W - u0, e1v = double(uv[3]) * H - v0;
        const double e2u = double(uv[4]) * W - u0, e2v = double(uv[5]) * H - v0;
        const double pu = x + 0.5 - u0, pv = y + 0.5 - v0;
        const double det = e1u * e2v - e2u * e1v;
        double b1 = std::max(0.0, (pu * e2v - e2u * pv) / det), b2 = std::max(0.0, (e1u * pv - pu * e1v) / det);
        if (b1 + b2 > 1.0) {
          const double sum = b1 + b2;
          b1 /= sum, b2 /= sum;
        }
        const double b0 = 1.0 - b1 - b2;
        out.barycentric[2 * s] = float(b1);
        out.barycentric[2 * s + 1] = float(b2);
        const int32_t* v = in.triangles + 3 * size_t(t);
        const V3 p0 = v3(in.positions + 3 * size_t(v[0])), p1 = v3(in.positions + 3 * size_t(v[1])),
                 p2 = v3(in.positions + 3 * size_t(v[2]));
        store(&out.position[3 * s], p0 * b0 + p1 * b1 + p2 * b2);
        V3 n0, n1, n2;
        if (in.corner_normals) {
          const float* cn = in.corner_normals + 9 * size_t(t);
          n0 = v3(cn), n1 = v3(cn + 3), n2 = v3(cn + 6);
        } else {
          n0 = vnormals[v[0]], n1 = vnormals[v[1]], n2 = vnormals[v[2]];
        }
        // Opposite corner normals can cancel: fall back to the face's own normal, then +z.
        const V3 face = normalized_or(cross(p1 - p0, p2 - p0), V3{0, 0, 1}, 1e-30);
        store(&out.normal[3 * s], normalized_or(n0 * b0 + n1 * b1 + n2 * b2, face, 1e-12));
        ++s;
      }
    }
  });
  throw_if_cancelled(cancel);

  if (in.margin > 0) {
    MarginPixels gutter = find_margin_pixels(owner.data(), W, H, in.margin, cancel);
    out.gutter_texel = std::move(gutter.pixel);
    out.gutter_source = std::move(gutter.source);
    for (int32_t& s : out.gutter_source) s = owner[s];  // texel -> its sample index
  }
  return out;
}

}  // namespace texsynth
