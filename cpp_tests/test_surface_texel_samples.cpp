// SPDX-License-Identifier: GPL-3.0-or-later
// sample_texels against analytic expectations (bilinear positions, exact texel counts of squares
// whose corners sit on texel corners or centres, overlap areas, gutter rings) and an independent
// brute-force point-in-triangle rasteriser.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "texsynth/common/errors.hpp"
#include "texsynth/common/rng.hpp"
#include "texsynth/surface/texel_samples.hpp"

using texsynth::sample_texels;
using texsynth::TexelSamples;

namespace {

// Loop triangles with per-corner UVs, built by hand.
struct UvMesh {
  std::vector<float> positions, uvs, normals;
  std::vector<int32_t> triangles;

  int32_t add_vertex(double x, double y, double z) {
    positions.insert(positions.end(), {float(x), float(y), float(z)});
    return int32_t(positions.size() / 3 - 1);
  }
  // Corner UVs given in UV units.
  int32_t add_triangle(std::array<int32_t, 3> v, std::array<std::array<double, 2>, 3> uv) {
    triangles.insert(triangles.end(), v.begin(), v.end());
    for (auto& c : uv) uvs.insert(uvs.end(), {float(c[0]), float(c[1])});
    return int32_t(triangles.size() / 3 - 1);
  }
  // A quad (two triangles 0-1-2, 0-2-3) with its own four vertices.
  void add_quad(std::array<std::array<double, 3>, 4> p, std::array<std::array<double, 2>, 4> uv) {
    int32_t v[4];
    for (int i = 0; i < 4; ++i) v[i] = add_vertex(p[i][0], p[i][1], p[i][2]);
    add_triangle({v[0], v[1], v[2]}, {uv[0], uv[1], uv[2]});
    add_triangle({v[0], v[2], v[3]}, {uv[0], uv[2], uv[3]});
  }
  // An axis-aligned UV rectangle [u0, u1] x [v0, v1] on a flat quad in the z = 0 plane at (u, v).
  void add_uv_rect(double u0, double v0, double u1, double v1) {
    add_quad({{{u0, v0, 0}, {u1, v0, 0}, {u1, v1, 0}, {u0, v1, 0}}}, {{{u0, v0}, {u1, v0}, {u1, v1}, {u0, v1}}});
  }
  int32_t num_triangles() const { return int32_t(triangles.size() / 3); }
  texsynth::TexelSampleInput input(int32_t w, int32_t h, int32_t margin = 2) const {
    texsynth::TexelSampleInput in;
    in.positions = positions.data();
    in.num_vertices = int32_t(positions.size() / 3);
    in.triangles = triangles.data();
    in.num_triangles = num_triangles();
    in.corner_uvs = uvs.data();
    in.corner_normals = normals.empty() ? nullptr : normals.data();
    in.width = w;
    in.height = h;
    in.margin = margin;
    return in;
  }
};

std::string error_of(const texsynth::TexelSampleInput& in) {
  try {
    sample_texels(in);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

// Unit parallelogram P(u, v) = O + u A + v B over UV [0,1]^2 (so piecewise-linear = bilinear).
const std::array<double, 3> kO{1, 2, 3}, kA{2, 0, 1}, kB{0, 3, -1};
std::array<double, 3> parallelogram(double u, double v) {
  return {kO[0] + u * kA[0] + v * kB[0], kO[1] + u * kA[1] + v * kB[1], kO[2] + u * kA[2] + v * kB[2]};
}
UvMesh unit_quad(bool mirrored = false) {
  UvMesh m;
  const double us[4] = {0, 1, 1, 0}, vs[4] = {0, 0, 1, 1};
  std::array<std::array<double, 3>, 4> p;
  std::array<std::array<double, 2>, 4> uv;
  for (int i = 0; i < 4; ++i) {
    p[i] = parallelogram(us[i], vs[i]);
    uv[i] = {mirrored ? 1 - us[i] : us[i], vs[i]};
  }
  m.add_quad(p, uv);
  return m;
}

// Texel indices covered by the samples, checking they are strictly ascending (so each once).
std::vector<int32_t> texels_of(const TexelSamples& s) {
  for (size_t i = 1; i < s.texel.size(); ++i) EXPECT_LT(s.texel[i - 1], s.texel[i]) << "sample " << i;
  return std::vector<int32_t>(s.texel.begin(), s.texel.end());
}

// Brute force: centres strictly inside a UV triangle (double precision), per texel the triangles.
// Centres within 1e-4 texel of a triangle's boundary go to `ambiguous` instead (UVs are snapped to 2^-16 texel).
std::map<int32_t, std::vector<int32_t>> brute_cover(const UvMesh& m, int w, int h, std::set<int32_t>* ambiguous) {
  std::map<int32_t, std::vector<int32_t>> cover;
  for (int32_t t = 0; t < m.num_triangles(); ++t) {
    const float* uv = &m.uvs[6 * size_t(t)];
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        // In texel units.
        double px = x + 0.5, py = y + 0.5, s[3];
        for (int k = 0; k < 3; ++k) {  // signed distances to the edge lines
          const float* a = uv + 2 * k;
          const float* b = uv + 2 * ((k + 1) % 3);
          const double ax = double(a[0]) * w, ay = double(a[1]) * h, bx = double(b[0]) * w, by = double(b[1]) * h;
          s[k] = ((bx - ax) * (py - ay) - (by - ay) * (px - ax)) / std::hypot(bx - ax, by - ay);
        }
        for (double sign : {1.0, -1.0}) {  // counter-clockwise, then mirrored
          const double lo = std::min({sign * s[0], sign * s[1], sign * s[2]});
          if (lo > 1e-4) cover[y * w + x].push_back(t);
          else if (lo > -1e-4 && ambiguous) ambiguous->insert(y * w + x);
        }
      }
  }
  return cover;
}

// A jittered triangulated grid over UV [lo, hi]^2 (one island), vertices shared, z = a bump.
UvMesh jittered_grid(int n, double lo, double hi, double jitter, uint64_t seed) {
  UvMesh m;
  texsynth::Rng rng(seed);
  std::vector<std::array<double, 2>> uv;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      double du = (i > 0 && i < n) ? jitter * (rng.uniform() - 0.5) : 0.0;
      double dv = (j > 0 && j < n) ? jitter * (rng.uniform() - 0.5) : 0.0;
      double u = lo + (hi - lo) * (i + du) / n, v = lo + (hi - lo) * (j + dv) / n;
      uv.push_back({u, v});
      m.add_vertex(u, v, 0.1 * std::sin(7 * u) * std::cos(5 * v));
    }
  auto id = [&](int i, int j) { return int32_t(j * (n + 1) + i); };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      int32_t a = id(i, j), b = id(i + 1, j), c = id(i + 1, j + 1), d = id(i, j + 1);
      if ((i + j) % 2) {
        m.add_triangle({a, b, c}, {uv[a], uv[b], uv[c]});
        m.add_triangle({a, c, d}, {uv[a], uv[c], uv[d]});
      } else {
        m.add_triangle({a, b, d}, {uv[a], uv[b], uv[d]});
        m.add_triangle({b, c, d}, {uv[b], uv[c], uv[d]});
      }
    }
  return m;
}

}  // namespace

TEST(SurfaceTexelSamples, UnitQuadAt4x4GivesSixteenBilinearSamples) {
  const UvMesh m = unit_quad();
  const TexelSamples s = sample_texels(m.input(4, 4, 0));
  ASSERT_EQ(s.size(), 16u);
  for (int32_t i = 0; i < 16; ++i) EXPECT_EQ(s.texel[i], i);
  EXPECT_EQ(s.num_overlapping_texels, 0);
  EXPECT_EQ(s.num_degenerate_triangles, 0);
  EXPECT_EQ(s.num_islands, 1);
  EXPECT_TRUE(s.gutter_texel.empty());
  double nx = kA[1] * kB[2] - kA[2] * kB[1], ny = kA[2] * kB[0] - kA[0] * kB[2], nz = kA[0] * kB[1] - kA[1] * kB[0];
  const double nl = std::sqrt(nx * nx + ny * ny + nz * nz);
  for (int32_t i = 0; i < 16; ++i) {
    const double u = (i % 4 + 0.5) / 4, v = (i / 4 + 0.5) / 4;
    const auto p = parallelogram(u, v);
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(s.position[3 * i + a], p[a], 1e-5) << "texel " << i;
    EXPECT_NEAR(s.normal[3 * i], nx / nl, 1e-6);
    EXPECT_NEAR(s.normal[3 * i + 1], ny / nl, 1e-6);
    EXPECT_NEAR(s.normal[3 * i + 2], nz / nl, 1e-6);
    EXPECT_EQ(s.island[i], 0);
    // The barycentrics reproduce the texel centre from the claiming triangle's UVs.
    const float* uv = &m.uvs[6 * size_t(s.triangle[i])];
    const double b1 = s.barycentric[2 * i], b2 = s.barycentric[2 * i + 1], b0 = 1 - b1 - b2;
    EXPECT_NEAR(b0 * uv[0] + b1 * uv[2] + b2 * uv[4], u, 1e-6);
    EXPECT_NEAR(b0 * uv[1] + b1 * uv[3] + b2 * uv[5], v, 1e-6);
  }
}

TEST(SurfaceTexelSamples, CentresOnTheSharedDiagonalAreClaimedOnce) {
  // At 4x4 the diagonal u = v of the unit quad runs through the centres of texels (i, i); try both
  // diagonals and both windings of the split.
  for (bool other_diagonal : {false, true})
    for (bool flip_winding : {false, true}) {
      UvMesh m;
      const std::array<std::array<double, 2>, 4> c{{{0, 0}, {1, 0}, {1, 1}, {0, 1}}};
      for (auto& p : c) m.add_vertex(p[0], p[1], 0);
      std::array<std::array<int32_t, 3>, 2> tris =
          other_diagonal ? std::array<std::array<int32_t, 3>, 2>{{{0, 1, 3}, {1, 2, 3}}}
                         : std::array<std::array<int32_t, 3>, 2>{{{0, 1, 2}, {0, 2, 3}}};
      for (auto t : tris) {
        if (flip_winding) std::swap(t[1], t[2]);
        m.add_triangle(t, {c[t[0]], c[t[1]], c[t[2]]});
      }
      const TexelSamples s = sample_texels(m.input(4, 4));
      EXPECT_EQ(texels_of(s).size(), 16u) << other_diagonal << flip_winding;
      EXPECT_EQ(s.num_overlapping_texels, 0);
    }
}

TEST(SurfaceTexelSamples, FansAroundVerticesOnTexelCentresCoverEachTexelOnce) {
  // A triangulated square whose every vertex sits exactly on a texel centre: the square spans
  // centres (2..10) in x and y, i.e. the region [2.5, 10.5]^2 in texel units. Under the documented
  // tie rule (a point on an edge belongs to the triangle a (+e, +e^2) nudge enters) the square
  // owns exactly the half-open centre range [2.5, 10.5) in both axes: texels 2..9, 64 texels.
  const int W = 16;
  UvMesh m;
  const int n = 4;  // 4x4 quads of 2 texels, centre vertices at odd+0.5 positions
  auto uvc = [&](int i) { return (2.5 + 2.0 * i) / W; };
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) m.add_vertex(uvc(i), uvc(j), 0);
  auto id = [&](int i, int j) { return int32_t(j * (n + 1) + i); };
  auto uv = [&](int32_t v) { return std::array<double, 2>{m.positions[3 * v], m.positions[3 * v + 1]}; };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      // Split each quad into four triangles around its centre (also a texel centre): 8-triangle
      // fans around every inner grid vertex, 4-fans around the quad centres.
      const int32_t centre = m.add_vertex((uvc(i) + uvc(i + 1)) / 2, (uvc(j) + uvc(j + 1)) / 2, 0);
      const int32_t ring[4] = {id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)};
      for (int k = 0; k < 4; ++k) {
        const int32_t a = ring[k], b = ring[(k + 1) % 4];
        const bool flip = (i + j + k) % 2;  // mixed windings: mirrored triangles are fine
        if (flip) {
          m.add_triangle({a, centre, b}, {uv(a), uv(centre), uv(b)});
        } else {
          m.add_triangle({a, b, centre}, {uv(a), uv(b), uv(centre)});
        }
      }
    }
  const TexelSamples s = sample_texels(m.input(W, W, 0));
  std::vector<int32_t> expected;
  for (int y = 2; y < 10; ++y)
    for (int x = 2; x < 10; ++x) expected.push_back(y * W + x);
  EXPECT_EQ(texels_of(s), expected);
  EXPECT_EQ(s.num_overlapping_texels, 0);
  EXPECT_EQ(s.num_islands, 1);
}

TEST(SurfaceTexelSamples, MatchesBruteForceCoverageOnAJitteredGrid) {
  // Generic positions: no centre on an edge, so strict point-in-triangle decides every texel. The
  // strong jitter folds some triangles over their neighbours: real overlaps, lowest triangle kept.
  const UvMesh m = jittered_grid(23, 0.03, 0.91, 0.8, 5);
  const int W = 97, H = 61;
  const TexelSamples s = sample_texels(m.input(W, H, 0));
  std::set<int32_t> ambiguous;
  const auto cover = brute_cover(m, W, H, &ambiguous);
  EXPECT_LT(ambiguous.size(), 5u);  // generic positions: (almost) no centre that close to an edge
  int64_t overlaps = 0;
  for (const auto& entry : cover) overlaps += entry.second.size() > 1;
  EXPECT_GT(overlaps, 0);
  EXPECT_GE(s.num_overlapping_texels, overlaps);
  EXPECT_LE(s.num_overlapping_texels, overlaps + int64_t(ambiguous.size()));
  ASSERT_GE(s.size(), cover.size());
  texels_of(s);
  size_t i = 0;
  for (const auto& [texel, tris] : cover) {
    while (i < s.size() && ambiguous.count(s.texel[i])) ++i;
    ASSERT_LT(i, s.size());
    ASSERT_EQ(s.texel[i], texel);
    EXPECT_EQ(s.triangle[i], tris[0]) << "texel " << texel;  // ascending: tris[0] is the lowest
    const float* uv = &m.uvs[6 * size_t(tris[0])];
    const double b1 = s.barycentric[2 * i], b2 = s.barycentric[2 * i + 1], b0 = 1 - b1 - b2;
    EXPECT_GE(b0, -1e-6);
    EXPECT_NEAR(b0 * uv[0] + b1 * uv[2] + b2 * uv[4], (texel % W + 0.5) / W, 1e-5);
    EXPECT_NEAR(b0 * uv[1] + b1 * uv[3] + b2 * uv[5], (texel / W + 0.5) / H, 1e-5);
    ++i;
  }
  while (i < s.size() && ambiguous.count(s.texel[i])) ++i;
  EXPECT_EQ(i, s.size());
}

TEST(SurfaceTexelSamples, CountsOverlapsAndKeepsTheLowestTriangle) {
  // In texel units (8x8 image, centres at k + 0.5): island A = [0.1, 4.3] x [0.2, 5.4] covers
  // x 0..3, y 0..4 (20 texels); island B = [2.2, 6.1] x [3.6, 7.7] covers x 2..5, y 4..7 (16).
  // Both: x 2..3, y 4 = 2 texels.
  UvMesh m;
  m.add_uv_rect(0.1 / 8, 0.2 / 8, 4.3 / 8, 5.4 / 8);
  m.add_uv_rect(2.2 / 8, 3.6 / 8, 6.1 / 8, 7.7 / 8);
  const TexelSamples s = sample_texels(m.input(8, 8, 0));
  EXPECT_EQ(s.num_overlapping_texels, 2);
  EXPECT_EQ(texels_of(s).size(), 20u + 16u - 2u);
  EXPECT_EQ(s.num_islands, 2);
  for (size_t i = 0; i < s.size(); ++i) {
    const int x = s.texel[i] % 8, y = s.texel[i] / 8;
    const bool in_a = x <= 3 && y <= 4;
    EXPECT_EQ(s.triangle[i] < 2, in_a) << "texel " << s.texel[i];
    EXPECT_EQ(s.island[i], in_a ? 0 : 1);
  }
  // A triangle exactly on top of another: its whole coverage overlaps.
  UvMesh twice = unit_quad();
  twice.add_triangle({0, 1, 2}, {{{0, 0}, {1, 0}, {1, 1}}});
  const TexelSamples s2 = sample_texels(twice.input(4, 4, 0));
  EXPECT_EQ(s2.size(), 16u);
  // Texels with x > y (6) and the diagonal x = y (4): a (+e, +e^2) nudge from the diagonal goes to x > y.
  EXPECT_EQ(s2.num_overlapping_texels, 10);
}

TEST(SurfaceTexelSamples, MirroredIslandSamplesLikeTheOriginal) {
  const UvMesh m = unit_quad(true);  // u -> 1 - u: both triangles have negative UV area
  const TexelSamples s = sample_texels(m.input(4, 4, 0));
  ASSERT_EQ(texels_of(s).size(), 16u);
  EXPECT_EQ(s.num_overlapping_texels, 0);
  EXPECT_EQ(s.num_degenerate_triangles, 0);
  EXPECT_EQ(s.num_islands, 1);
  for (int32_t i = 0; i < 16; ++i) {
    const auto p = parallelogram(1 - (i % 4 + 0.5) / 4, (i / 4 + 0.5) / 4);
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(s.position[3 * i + a], p[a], 1e-5) << "texel " << i;
  }
}

TEST(SurfaceTexelSamples, ZeroAreaUvTrianglesAreSkippedAndCounted) {
  UvMesh m = unit_quad();
  const int32_t a = m.add_vertex(5, 5, 5), b = m.add_vertex(6, 5, 5), c = m.add_vertex(5, 6, 5);
  m.add_triangle({a, b, c}, {{{0.3, 0.3}, {0.3, 0.3}, {0.3, 0.3}}});          // collapsed to a point
  m.add_triangle({a, b, c}, {{{0.1, 0.1}, {0.9, 0.9}, {0.5, 0.5}}});          // collinear
  m.add_triangle({a, b, c}, {{{0.1, 0.1}, {0.9, 0.9}, {0.5000001, 0.5}}});   // float-rounding sliver
  const TexelSamples s = sample_texels(m.input(4, 4, 0));
  EXPECT_EQ(s.num_degenerate_triangles, 3);
  EXPECT_EQ(s.num_overlapping_texels, 0);
  EXPECT_EQ(texels_of(s).size(), 16u);
  for (int32_t t : s.triangle) EXPECT_LT(t, 2);
  EXPECT_EQ(s.num_islands, 1);
  EXPECT_EQ(s.triangle_island, (std::vector<int32_t>{0, 0, -1, -1, -1}));
}

TEST(SurfaceTexelSamples, RejectsNonFiniteInputNamingTheTriangle) {
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  UvMesh m = unit_quad();
  {
    UvMesh t = m;
    t.positions[3 * 3 + 1] = nan;  // vertex 3: used by triangle 1 only
    EXPECT_NE(error_of(t.input(4, 4)).find("triangle 1: position of vertex 3 is NaN"), std::string::npos)
        << error_of(t.input(4, 4));
  }
  {
    UvMesh t = m;
    t.uvs[6 * 1 + 2 * 2] = inf;
    EXPECT_NE(error_of(t.input(4, 4)).find("triangle 1: UV of corner 2 is NaN or infinite"), std::string::npos)
        << error_of(t.input(4, 4));
  }
  {
    UvMesh t = m;
    t.normals.assign(2 * 9, 0.f);
    t.normals[4] = nan;
    EXPECT_NE(error_of(t.input(4, 4)).find("triangle 0: normal of corner 1"), std::string::npos) << error_of(t.input(4, 4));
  }
  {
    UvMesh t = m;
    t.add_vertex(nan, 0, 0);  // loose vertex
    EXPECT_NE(error_of(t.input(4, 4)).find("vertex 4 (used by no triangle)"), std::string::npos) << error_of(t.input(4, 4));
  }
}

TEST(SurfaceTexelSamples, RejectsOutOfRangeIndicesAndBadSizes) {
  UvMesh m = unit_quad();
  {
    UvMesh t = m;
    t.triangles[4] = 4;
    EXPECT_NE(error_of(t.input(4, 4)).find("triangle 1 references vertex 4 (mesh has 4 vertices)"), std::string::npos)
        << error_of(t.input(4, 4));
    t.triangles[4] = -1;
    EXPECT_NE(error_of(t.input(4, 4)).find("references vertex -1"), std::string::npos);
  }
  EXPECT_NE(error_of(m.input(0, 4)).find("at least 1 x 1"), std::string::npos);
  EXPECT_NE(error_of(m.input(4, -2)).find("at least 1 x 1"), std::string::npos);
  EXPECT_NE(error_of(m.input(4, 4, -1)).find("margin"), std::string::npos);
  EXPECT_NE(error_of(m.input(4, 4, texsynth::kMaxMarginTexels + 1)).find("margin"), std::string::npos);
  EXPECT_NE(error_of(m.input(70000, 1)).find("limited to 65536"), std::string::npos);
  EXPECT_THROW(texsynth::estimate_texel_sample_bytes(0, 5), std::invalid_argument);
}

TEST(SurfaceTexelSamples, RefusesHugeImagesStatingTheMemory) {
  const UvMesh m = unit_quad();
  // 48 bytes per texel (documented bound): 10000 x 10000 -> 4800 MB.
  EXPECT_EQ(texsynth::estimate_texel_sample_bytes(10000, 10000), int64_t(10000) * 10000 * 48);
  const std::string e = error_of(m.input(10000, 10000));
  EXPECT_NE(e.find("10000 x 10000 image needs up to 4800 MB"), std::string::npos) << e;
  EXPECT_NE(e.find("8192 x 8192"), std::string::npos) << e;
  EXPECT_NE(error_of(m.input(8193, 8192)), "");
  EXPECT_LE(texsynth::estimate_texel_sample_bytes(8192, 8192), texsynth::kMaxTexelSampleBytes);
}

TEST(SurfaceTexelSamples, GutterIsTheEuclideanRingAroundASquareIsland) {
  // A UV square over texel corners 4..8 in a 16x16 image covers texels 4..7 in x and y.
  const int W = 16;
  UvMesh m;
  m.add_uv_rect(4.0 / W, 4.0 / W, 8.0 / W, 8.0 / W);
  const TexelSamples s = sample_texels(m.input(W, W, 2));
  ASSERT_EQ(s.size(), 16u);
  // Within 2 texels (Euclidean) of a 4x4 block: 4 sides x 4 x 2 strips + one diagonal (1,1) per corner.
  ASSERT_EQ(s.gutter_texel.size(), 36u);
  ASSERT_EQ(s.gutter_source.size(), 36u);
  for (size_t i = 0; i < s.gutter_texel.size(); ++i) {
    const int x = s.gutter_texel[i] % W, y = s.gutter_texel[i] / W;
    if (i > 0) {
      EXPECT_LT(s.gutter_texel[i - 1], s.gutter_texel[i]);
    }
    // Nearest covered texel: the square clamps the coordinates into 4..7.
    const int cx = std::clamp(x, 4, 7), cy = std::clamp(y, 4, 7);
    EXPECT_LE((x - cx) * (x - cx) + (y - cy) * (y - cy), 4) << "texel " << x << "," << y;
    ASSERT_GE(s.gutter_source[i], 0);
    ASSERT_LT(size_t(s.gutter_source[i]), s.size());
    EXPECT_EQ(s.texel[s.gutter_source[i]], cy * W + cx) << "texel " << x << "," << y;
  }
  EXPECT_TRUE(sample_texels(m.input(W, W, 0)).gutter_texel.empty());
}

TEST(SurfaceTexelSamples, GutterMatchesBruteForceNearestWithTies) {
  // Two islands whose gutters meet, one touching the image border; ties go to the lowest texel index.
  UvMesh m = jittered_grid(6, 0.0, 0.35, 0.6, 9);
  UvMesh other = jittered_grid(5, 0.45, 0.8, 0.6, 10);
  const int32_t offset = int32_t(m.positions.size() / 3);
  m.positions.insert(m.positions.end(), other.positions.begin(), other.positions.end());
  for (int32_t v : other.triangles) m.triangles.push_back(v + offset);
  m.uvs.insert(m.uvs.end(), other.uvs.begin(), other.uvs.end());
  const int W = 40, H = 33, M = 3;
  const TexelSamples s = sample_texels(m.input(W, H, M));
  EXPECT_EQ(s.num_islands, 2);
  std::set<int32_t> covered(s.texel.begin(), s.texel.end());
  std::vector<int32_t> want_texel, want_source;
  for (int32_t p = 0; p < W * H; ++p) {
    if (covered.count(p)) continue;
    int best_d2 = M * M + 1, best = -1;
    for (int32_t q : covered) {  // ascending: the first at the smallest distance wins ties
      const int dx = p % W - q % W, dy = p / W - q / W;
      if (dx * dx + dy * dy < best_d2) best_d2 = dx * dx + dy * dy, best = q;
    }
    if (best >= 0) want_texel.push_back(p), want_source.push_back(best);
  }
  ASSERT_EQ(s.gutter_texel, want_texel);
  for (size_t i = 0; i < want_source.size(); ++i) EXPECT_EQ(s.texel[s.gutter_source[i]], want_source[i]);
}

TEST(SurfaceTexelSamples, IslandsFollowUvSeams) {
  // A strip of two quads sharing the mesh edge 1-4: welded UVs -> one island; a UV seam on that edge
  // (the second quad's UVs moved, or only one of its corners) -> two.
  auto strip = [](int seam) {
    UvMesh m;
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 3; ++i) m.add_vertex(i, j, 0);
    // vertices 0 1 2 / 3 4 5; UVs scaled by 0.25
    auto uv = [](int i, int j, double shift) { return std::array<double, 2>{0.25 * i + shift, 0.25 * j}; };
    m.add_triangle({0, 1, 4}, {uv(0, 0, 0), uv(1, 0, 0), uv(1, 1, 0)});
    m.add_triangle({0, 4, 3}, {uv(0, 0, 0), uv(1, 1, 0), uv(0, 1, 0)});
    const double s = seam ? 0.3 : 0.0;
    m.add_triangle({1, 2, 5}, {uv(1, 0, s), uv(2, 0, s), uv(2, 1, s)});
    m.add_triangle({1, 5, 4}, {uv(1, 0, seam == 2 ? 0 : s), uv(2, 1, s), uv(1, 1, s)});
    return m;
  };
  const TexelSamples welded = sample_texels(strip(0).input(16, 16));
  EXPECT_EQ(welded.num_islands, 1);
  EXPECT_EQ(welded.triangle_island, (std::vector<int32_t>{0, 0, 0, 0}));
  const TexelSamples cut = sample_texels(strip(1).input(16, 16));
  EXPECT_EQ(cut.num_islands, 2);
  EXPECT_EQ(cut.triangle_island, (std::vector<int32_t>{0, 0, 1, 1}));
  const TexelSamples one_corner = sample_texels(strip(2).input(16, 16));  // one UV corner in common is not enough
  EXPECT_NE(one_corner.triangle_island[0], one_corner.triangle_island[3]);
  for (size_t i = 0; i < cut.size(); ++i) EXPECT_EQ(cut.island[i], cut.triangle_island[cut.triangle[i]]);
  std::set<int32_t> islands(cut.island.begin(), cut.island.end());
  EXPECT_EQ(islands, (std::set<int32_t>{0, 1}));
}

TEST(SurfaceTexelSamples, InterpolatesGivenCornerNormalsAndRenormalises) {
  UvMesh m;
  for (auto p : {std::array<double, 3>{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}) m.add_vertex(p[0], p[1], p[2]);
  m.add_triangle({0, 1, 2}, {{{0, 0}, {1, 0}, {0, 1}}});
  m.normals = {1, 0, 0, 0, 1, 0, 0, 0, 1};  // corner normals: the three axes
  const TexelSamples s = sample_texels(m.input(8, 8, 0));
  ASSERT_GT(s.size(), 0u);
  for (size_t i = 0; i < s.size(); ++i) {
    const double b1 = s.barycentric[2 * i], b2 = s.barycentric[2 * i + 1], b0 = 1 - b1 - b2;
    const double l = std::sqrt(b0 * b0 + b1 * b1 + b2 * b2);
    EXPECT_NEAR(s.normal[3 * i], b0 / l, 1e-6);
    EXPECT_NEAR(s.normal[3 * i + 1], b1 / l, 1e-6);
    EXPECT_NEAR(s.normal[3 * i + 2], b2 / l, 1e-6);
    // position = (u, v, 0) at the texel centre
    EXPECT_NEAR(s.position[3 * i], (s.texel[i] % 8 + 0.5) / 8, 1e-6);
    EXPECT_NEAR(s.position[3 * i + 1], (s.texel[i] / 8 + 0.5) / 8, 1e-6);
  }
  // Without corner normals: area-weighted vertex normals of a folded pair of triangles (a roof):
  // each flank weighted by its area, so the shared ridge vertices get the sum of the face normals.
  UvMesh roof;
  for (auto p : {std::array<double, 3>{0, 0, 0}, {0, 1, 0}, {1, 0, 1}, {-2, 0, 2}}) roof.add_vertex(p[0], p[1], p[2]);
  roof.add_triangle({0, 2, 1}, {{{0, 0}, {0.5, 0}, {0, 0.5}}});
  roof.add_triangle({0, 1, 3}, {{{0.6, 0.6}, {0.6, 1}, {1, 0.6}}});
  const TexelSamples r = sample_texels(roof.input(32, 32, 0));
  // Face normals x 2 area: (p2-p0)x(p1-p0) = (1,0,1)x(0,1,0) = (-1,0,1); (p1-p0)x(p3-p0) = (0,1,0)x(-2,0,2) = (2,0,2).
  const double n0[3] = {-1 / std::sqrt(2.0), 0, 1 / std::sqrt(2.0)}, sum[3] = {1, 0, 3};
  const double sl = std::sqrt(10.0);
  for (size_t i = 0; i < r.size(); ++i) {
    if (r.triangle[i] != 0) continue;
    const double b1 = r.barycentric[2 * i], b2 = r.barycentric[2 * i + 1], b0 = 1 - b1 - b2;
    // corner 0 = vertex 0 (ridge), corner 1 = vertex 2 (flank 0 only), corner 2 = vertex 1 (ridge)
    double n[3], l = 0;
    for (int a = 0; a < 3; ++a) n[a] = (b0 + b2) * sum[a] / sl + b1 * n0[a], l += n[a] * n[a];
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(r.normal[3 * i + a], n[a] / std::sqrt(l), 1e-5);
  }
}

TEST(SurfaceTexelSamples, BitIdenticalAtOneAndTwoThreads) {
  // ~45k triangles in islands over a 256x200 image, plus an overlapping island.
  UvMesh m = jittered_grid(150, 0.02, 0.97, 0.7, 21);
  UvMesh extra = jittered_grid(20, 0.3, 0.6, 0.7, 22);
  const int32_t offset = int32_t(m.positions.size() / 3);
  m.positions.insert(m.positions.end(), extra.positions.begin(), extra.positions.end());
  for (int32_t v : extra.triangles) m.triangles.push_back(v + offset);
  m.uvs.insert(m.uvs.end(), extra.uvs.begin(), extra.uvs.end());
  auto run = [&](int threads) {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, threads);
    return sample_texels(m.input(256, 200, 3));
  };
  const TexelSamples a = run(1), b = run(2);
  EXPECT_GT(a.num_overlapping_texels, 0);
  EXPECT_EQ(a.num_overlapping_texels, b.num_overlapping_texels);
  EXPECT_EQ(a.num_islands, b.num_islands);
  EXPECT_EQ(a.texel, b.texel);
  EXPECT_EQ(a.triangle, b.triangle);
  EXPECT_EQ(a.island, b.island);
  EXPECT_EQ(a.gutter_texel, b.gutter_texel);
  EXPECT_EQ(a.gutter_source, b.gutter_source);
  auto same_bits = [](const auto& x, const auto& y) {
    return x.size() == y.size() && std::memcmp(x.data(), y.data(), x.size() * sizeof(float)) == 0;
  };
  EXPECT_TRUE(same_bits(a.barycentric, b.barycentric));
  EXPECT_TRUE(same_bits(a.position, b.position));
  EXPECT_TRUE(same_bits(a.normal, b.normal));
}

TEST(SurfaceTexelSamples, StopsWhenCancelled) {
  const UvMesh m = jittered_grid(40, 0.0, 1.0, 0.5, 3);
  std::atomic<bool> cancel{true};
  EXPECT_THROW(sample_texels(m.input(512, 512), &cancel), texsynth::Cancelled);
}
