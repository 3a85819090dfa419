// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/neighbourhood/round_rings.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#if defined(__linux__)
#include <sys/mman.h>
#endif

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <string>

#include "texsynth/common/errors.hpp"
#include "texsynth/mesh/vec_math.hpp"
#include "texsynth/mesh/walk_mesh.hpp"

namespace texsynth {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kTwoPi = 2 * kPi;
// Texel centres clamped into their face by the caller may still sit a rounding error outside.
constexpr double kBarycentricTolerance = 1e-4;

void validate(const TriangleMeshInput& mesh, const SurfacePoints& pts, const RoundRingsParams& p) {
  if (p.rings < 1 || p.rings > kMaxRings)
    throw std::invalid_argument("round rings: rings (K) must be 1.." + std::to_string(kMaxRings) + ", got " +
                                std::to_string(p.rings));
  if (!std::isfinite(p.facing_limit_degrees) || p.facing_limit_degrees <= 0 || p.facing_limit_degrees > 180)
    throw std::invalid_argument("round rings: facing_limit_degrees must be in (0, 180]");
  if (p.max_steps < 1) throw std::invalid_argument("round rings: max_steps must be >= 1");
  if (!(p.max_megabytes > 0)) throw std::invalid_argument("round rings: max_megabytes must be > 0");
  if (mesh.num_vertices < 0 || mesh.num_triangles < 0 || pts.num_points < 0)
    throw std::invalid_argument("round rings: negative vertex, triangle or point count");
  // Triangle index and edge share one int32 in WalkTriangle::across.
  if (mesh.num_triangles > (std::numeric_limits<int32_t>::max() >> 2))
    throw std::invalid_argument("round rings: too many triangles (" + std::to_string(mesh.num_triangles) + ")");
  if ((mesh.num_vertices > 0 && !mesh.positions) || (mesh.num_triangles > 0 && !mesh.triangles) ||
      (pts.num_points > 0 && (!pts.triangle || !pts.barycentric || !pts.radius)))
    throw std::invalid_argument("round rings: missing positions, triangles or point data");
  for (int64_t i = 0; i < int64_t(mesh.num_vertices) * 3; ++i)
    if (!std::isfinite(mesh.positions[i]))
      throw std::invalid_argument("round rings: position of vertex " + std::to_string(i / 3) + " is NaN or infinite");
  for (int64_t i = 0; i < int64_t(mesh.num_triangles) * 3; ++i)
    if (mesh.triangles[i] < 0 || mesh.triangles[i] >= mesh.num_vertices)
      throw std::invalid_argument("round rings: triangle " + std::to_string(i / 3) + " references vertex " +
                                  std::to_string(mesh.triangles[i]) + " (mesh has " +
                                  std::to_string(mesh.num_vertices) + " vertices)");
  for (int32_t i = 0; i < pts.num_points; ++i) {
    if (pts.triangle[i] < 0 || pts.triangle[i] >= mesh.num_triangles)
      throw std::invalid_argument("round rings: point " + std::to_string(i) + " is in triangle " +
                                  std::to_string(pts.triangle[i]) + " (mesh has " +
                                  std::to_string(mesh.num_triangles) + " triangles)");
    const double b1 = pts.barycentric[2 * size_t(i)], b2 = pts.barycentric[2 * size_t(i) + 1];
    if (!std::isfinite(b1) || !std::isfinite(b2) || b1 < -kBarycentricTolerance || b2 < -kBarycentricTolerance ||
        b1 + b2 > 1 + kBarycentricTolerance) {
      std::ostringstream msg;
      msg << "round rings: barycentrics of point " << i << " (" << b1 << ", " << b2
          << ") are not inside the triangle (need b1, b2 >= 0 and b1 + b2 <= 1)";
      throw std::invalid_argument(msg.str());
    }
    // Not clamped: r comes from the caller's scale field, which is where a zero or NaN must be fixed.
    if (!std::isfinite(pts.radius[i]) || pts.radius[i] <= 0.f)
      throw std::invalid_argument("round rings: radius of point " + std::to_string(i) + " must be finite and > 0");
  }
  const RoundRingsMemory mem =
      estimate_round_rings_memory(pts.num_points, mesh.num_triangles, mesh.num_vertices, p.rings);
  if (double(mem.peak_bytes) > p.max_megabytes * 1e6) {
    std::ostringstream msg;
    msg << "round rings: " << pts.num_points << " points with K = " << p.rings << " rings need about "
        << std::llround(double(mem.peak_bytes) / 1e6) << " MB (limit " << p.max_megabytes
        << " MB); use fewer rings or points";
    throw std::invalid_argument(msg.str());
  }
}

// The distinct walk directions of rings 1..K: ring m's bin a is at angle index a·L/(8m) on a grid of
// L = 8·lcm(1..K) steps, so one walk per distinct index serves every ring with a bin there (48 walks
// instead of 80 for K = 4, total walked length 176·r instead of 240·r).
struct Target {
  int ring;   // 1-based
  int entry;  // within the point's block
};
struct Direction {
  double c, s;
  int count = 0;
  std::array<Target, kMaxRings> targets{};  // ascending ring
};

std::vector<Direction> walk_directions(int rings) {
  int lcm = 1;
  for (int m = 2; m <= rings; ++m) lcm = lcm / std::gcd(lcm, m) * m;
  const int grid = 8 * lcm;
  std::vector<int> slot(size_t(grid), -1);
  std::vector<Direction> dirs;
  for (int m = 1; m <= rings; ++m)
    for (int a = 0; a < ring_bins(m); ++a) {
      const int g = a * (grid / ring_bins(m));
      if (slot[g] < 0) {
        slot[g] = int(dirs.size());
        Direction d;
        d.c = std::cos(kTwoPi * g / grid);
        d.s = std::sin(kTwoPi * g / grid);
        dirs.push_back(d);
      }
      Direction& d = dirs[slot[g]];
      d.targets[d.count++] = {m, ring_offset(m) + a};
    }
  return dirs;
}

// β1, β2 to 16 bits (β0 implied). The walk keeps β0 + β1 + β2 = 1 up to rounding, so no
// renormalisation: clamp, round half up, and if both rounded up past 1 take the excess off the larger.
RingPoint quantise(int32_t tri, double b1, double b2) {
  int32_t q1 = int32_t(std::clamp(b1, 0.0, 1.0) * 65535.0 + 0.5), q2 = int32_t(std::clamp(b2, 0.0, 1.0) * 65535.0 + 0.5);
  if (q1 + q2 > 65535) (q1 >= q2 ? q1 : q2) -= q1 + q2 - 65535;
  return {tri, uint16_t(q1), uint16_t(q2)};
}

struct PointFrame {
  V3 n, t0;
};

// Smooth normal n (welded vertex normals interpolated, else the face's, else +z) and the reference
// tangent t0, geometry only so the rings never depend on the direction field: the containing
// triangle's first edge rotated (not projected) from the face plane into the tangent plane, so the
// walks, which rotate back, start exactly along that edge at angle 0 even where n is tilted against
// the face (next to a crease or fin). Degenerate faces: the first edge with a length, projected; else
// any perpendicular.
PointFrame point_frame(const TriangleMeshInput& m, const WalkMesh& w, int32_t t, const double b[3]) {
  const int32_t* c = m.triangles + 3 * size_t(t);
  V3 n;
  for (int k = 0; k < 3; ++k) n = n + w.vertex_normal[w.weld[c[k]]] * b[k];
  const WalkTriangle& wt = w.tris[t];
  n = normalized_or(n, wt.degenerate ? V3{0, 0, 1} : wt.normal, 1e-12);
  PointFrame f{n, {}};
  if (!wt.degenerate) {
    const double cn = dot(wt.normal, n);
    if (1 + cn > 1e-9) {
      const V3 edge = normalized_or(mesh_position(m, c[1]) - mesh_position(m, c[0]), V3{});
      f.t0 = normalized_or(project_to_plane(rotate_between(edge, wt.normal, n, cn), n), V3{});
      if (norm(f.t0) > 0) return f;
    }
  }
  for (int k = 0; k < 3; ++k) {
    const V3 e = project_to_plane(mesh_position(m, c[(k + 1) % 3]) - mesh_position(m, c[k]), n);
    const double len = norm(e);
    if (len > 1e-12 * (1 + norm(mesh_position(m, c[k]))) && std::isfinite(len)) {
      f.t0 = e * (1.0 / len);
      return f;
    }
  }
  f.t0 = any_perpendicular(n);
  return f;
}

class PointWalker {
 public:
  PointWalker(const TriangleMeshInput& m, const WalkMesh& w, const std::vector<Direction>& dirs, double cos_limit,
              int32_t max_steps)
      : m_(m), w_(w), dirs_(dirs), cos_limit_(cos_limit), max_steps_(max_steps) {}

  // Fills the reached entries of one point's block; the others keep triangle -1.
  void run(int32_t t, const double beta[3], double r, const PointFrame& f, RingPoint* out) const {
    const WalkTriangle& wt = w_.tris[t];
    if (wt.degenerate) return;
    const double c = dot(f.n, wt.normal);
    if (c < cos_limit_) return;  // the start face itself turns away from the smooth normal
    V3 t0 = 1 + c > 1e-9 ? rotate_between(f.t0, f.n, wt.normal, c) : f.t0;
    t0 = normalized_or(project_to_plane(t0, wt.normal), any_perpendicular(wt.normal));
    const V3 b0 = cross(wt.normal, t0);
    // Barycentric rates of t0 and b0 in the start face: a direction's rates are their cos/sin mix.
    const Start start{t,
                      {beta[0], beta[1], beta[2]},
                      t0,
                      b0,
                      {dot(wt.grad1, t0), dot(wt.grad2, t0)},
                      {dot(wt.grad1, b0), dot(wt.grad2, b0)},
                      r,
                      f.n};
    for (const Direction& d : dirs_) walk(start, d, out);
  }

 private:
  struct Start {
    int32_t t;
    double beta[3];
    V3 t0, b0;
    double rate_t[2], rate_b[2];
    double r;
    V3 centre_n;
  };

  // One straightest-geodesic walk: a straight line in barycentric coordinates inside each face
  // (β(s) = β + s·rate), unfolded across each edge, recording the targets (m·r) it passes.
  void walk(const Start& st, const Direction& d, RingPoint* out) const {
    int32_t t = st.t;
    double beta[3] = {st.beta[0], st.beta[1], st.beta[2]};
    double rate[3];
    rate[1] = d.c * st.rate_t[0] + d.s * st.rate_b[0];
    rate[2] = d.c * st.rate_t[1] + d.s * st.rate_b[1];
    rate[0] = -(rate[1] + rate[2]);
    V3 dir = st.t0 * d.c + st.b0 * d.s;
    double travelled = 0;
    int next = 0;
    int32_t steps = 0;
    const WalkTriangle* wt = &w_.tris[t];
    for (;;) {
      // The exit edge: first β to reach 0, s = β_i / -rate_i, compared by cross-multiplying so only
      // the winner costs a division.
      int exit = -1;
      double num = 0, den = 1;
      for (int i = 0; i < 3; ++i)
        if (rate[i] < 0) {
          const double b = std::max(beta[i], 0.0);
          if (exit < 0 || b * den < num * -rate[i]) exit = i, num = b, den = -rate[i];
        }
      // Ring points reached inside this face.
      while (next < d.count) {
        const double s = d.targets[next].ring * st.r - travelled;
        if (exit >= 0 && s * den > num) break;
        out[d.targets[next].entry] = quantise(t, beta[1] + s * rate[1], beta[2] + s * rate[2]);
        ++next;
      }
      if (next == d.count || exit < 0) return;
      // To the exit edge: corners j -> k, the face's edge j.
      const double s_exit = num / den;
      const int j = (exit + 1) % 3, k = (exit + 2) % 3;
      const double bk = std::clamp(beta[k] + s_exit * rate[k], 0.0, 1.0);
      travelled += s_exit;
      const int32_t across = wt->across[j];
      if (across < 0 || ++steps > max_steps_) return;
      const int32_t nt = across >> 2, ne = across & 3;
      const WalkTriangle* nw = &w_.tris[nt];
      if (dot(nw->normal, st.centre_n) < cos_limit_) return;  // back side of a thin part, far side of a small sphere
      // Unfold = rotate about the shared edge: keep the component along the edge; the leaving
      // component (along our inward perpendicular n × ê, negative) turns into the neighbour's plane,
      // where n' × ê points the same way across the edge. Unit length is kept without a square root.
      const int32_t* cc = m_.triangles + 3 * size_t(t);
      const V3 edge = (mesh_position(m_, cc[k]) - mesh_position(m_, cc[j])) * wt->inv_edge[j];
      const double along = dot(dir, edge), leaving = dot(dir, cross(wt->normal, edge));
      dir = edge * along + cross(nw->normal, edge) * leaving;
      // Same edge, reversed in the neighbour (consistent orientation): its corner ne is our k.
      beta[ne] = bk, beta[(ne + 1) % 3] = 1 - bk, beta[(ne + 2) % 3] = 0;
      t = nt;
      wt = nw;
      rate[1] = dot(wt->grad1, dir), rate[2] = dot(wt->grad2, dir), rate[0] = -(rate[1] + rate[2]);
    }
  }

  const TriangleMeshInput& m_;
  const WalkMesh& w_;
  const std::vector<Direction>& dirs_;
  double cos_limit_;
  int32_t max_steps_;
};

// The ring table is hundreds of MB written once in parallel: with 4 KB pages its first touch is
// ~100k page faults, a large share of the whole build on virtualised hosts. Transparent huge pages
// (where the kernel offers them on request) cut that 500-fold; elsewhere this does nothing.
void advise_huge_pages(void* data, size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  constexpr uintptr_t kHuge = uintptr_t(2) << 20;
  const uintptr_t begin = (reinterpret_cast<uintptr_t>(data) + kHuge - 1) & ~(kHuge - 1);
  const uintptr_t end = (reinterpret_cast<uintptr_t>(data) + bytes) & ~(kHuge - 1);
  if (end > begin) madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);  // advisory: errors ignored
#else
  (void)data, (void)bytes;
#endif
}

}  // namespace

RoundRingsMemory estimate_round_rings_memory(int64_t num_points, int64_t num_triangles, int64_t num_vertices,
                                             int rings) {
  RoundRingsMemory mem;
  const int64_t entries = ring_entries(std::clamp(rings, 0, kMaxRings));
  mem.result_bytes = num_points * (entries * int64_t(sizeof(RingPoint)) + 6 * int64_t(sizeof(float)));
  mem.peak_bytes = mem.result_bytes + walk_mesh_peak_bytes(num_triangles, num_vertices);
  return mem;
}

RoundRings build_round_rings(const TriangleMeshInput& mesh, const SurfacePoints& pts, const RoundRingsParams& p) {
  validate(mesh, pts, p);
  const std::atomic<bool>* cancel = p.cancel;
  throw_if_cancelled(cancel);
  const WalkMesh w = build_walk_mesh(mesh, cancel);
  throw_if_cancelled(cancel);

  RoundRings out;
  out.num_points = pts.num_points;
  out.rings = p.rings;
  out.entries_per_point = ring_entries(p.rings);
  out.points.resize(size_t(pts.num_points) * size_t(out.entries_per_point));
  advise_huge_pages(out.points.data(), out.points.size() * sizeof(RingPoint));
  out.normal.resize(3 * size_t(pts.num_points));
  out.tangent.resize(3 * size_t(pts.num_points));
  const std::vector<Direction> dirs = walk_directions(p.rings);
  // 180° would make cos exactly -1 and the test vacuous, which is what "no limit" means.
  const double cos_limit = std::cos(p.facing_limit_degrees * kPi / 180.0);
  const PointWalker walker(mesh, w, dirs, cos_limit, p.max_steps);
  std::array<std::atomic<int64_t>, kMaxRings> invalid{};
  const int entries = out.entries_per_point;
  // Every point independently into its own slots: identical bytes for any thread count or chunking.
  // Integer invalid counts are summed per chunk, exact in any order.
  // The cancel flag is read every 64 points (~10 µs of work), however large the partitioner's chunks.
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, pts.num_points, 64), [&](const tbb::blocked_range<int32_t>& range) {
    std::array<int64_t, kMaxRings> local{};
    for (int32_t i = range.begin(); i < range.end(); ++i) {
      if (((i - range.begin()) & 63) == 0) throw_if_cancelled(cancel);
      const int32_t t = pts.triangle[i];
      double b[3] = {std::max(0.0, double(pts.barycentric[2 * size_t(i)])),
                     std::max(0.0, double(pts.barycentric[2 * size_t(i) + 1])), 0};
      if (b[0] + b[1] > 1) {  // within the tolerance validate() allowed: back onto the edge
        const double s = b[0] + b[1];
        b[0] /= s, b[1] /= s;
      }
      const double beta[3] = {1 - b[0] - b[1], b[0], b[1]};
      const PointFrame f = point_frame(mesh, w, t, beta);
      store(&out.normal[3 * size_t(i)], f.n);
      store(&out.tangent[3 * size_t(i)], f.t0);
      RingPoint* block = out.points.data() + size_t(i) * size_t(entries);
      std::fill_n(block, entries, RingPoint{-1, 0, 0});
      walker.run(t, beta, double(pts.radius[i]), f, block);
      for (int m = 1; m <= p.rings; ++m)
        for (int a = 0; a < ring_bins(m); ++a) local[m - 1] += block[ring_offset(m) + a].triangle < 0;
    }
    for (int m = 0; m < p.rings; ++m) invalid[m] += local[m];
  });
  out.invalid_per_ring.resize(size_t(p.rings));
  for (int m = 0; m < p.rings; ++m) {
    out.invalid_per_ring[m] = invalid[m].load();
    out.invalid_count += out.invalid_per_ring[m];
  }
  return out;
}

float direction_angle(const RoundRings& rings, int32_t point, const float dir[3], bool* defined) {
  if (point < 0 || point >= rings.num_points)
    throw std::invalid_argument("direction_angle: point " + std::to_string(point) + " out of range (" +
                                std::to_string(rings.num_points) + " points)");
  const V3 n = v3(&rings.normal[3 * size_t(point)]), t0 = v3(&rings.tangent[3 * size_t(point)]);
  const V3 d = v3(dir);
  const V3 p = project_to_plane(d, n);
  const double x = dot(p, t0), y = dot(p, cross(n, t0));
  const double len = std::sqrt(x * x + y * y), full = norm(d);
  const bool ok = std::isfinite(len) && std::isfinite(full) && len > 1e-9 * full && len > 0;
  if (defined) *defined = ok;
  if (!ok) return 0.f;
  double a = std::atan2(y, x);
  if (a < 0) a += kTwoPi;
  const float f = float(a);
  return f >= float(kTwoPi) ? 0.f : f;  // rounding up to 2π wraps to 0, keeping [0, 2π)
}

RingSample ring_sample(int ring, float phi) {
  if (ring < 1 || ring > kMaxRings)
    throw std::invalid_argument("ring_sample: ring must be 1.." + std::to_string(kMaxRings) + ", got " +
                                std::to_string(ring));
  const int bins = ring_bins(ring);
  double x = std::isfinite(phi) ? double(phi) / kTwoPi * bins : 0.0;
  x -= std::floor(x / bins) * bins;  // [0, bins], the upper end only by rounding
  const double f = std::floor(x);
  RingSample s;
  s.bin0 = int(f) % bins;
  s.bin1 = (s.bin0 + 1) % bins;
  s.weight = float(x - f);
  if (!(s.weight < 1.f)) s.weight = 0.f, s.bin0 = s.bin1, s.bin1 = (s.bin0 + 1) % bins;
  return s;
}

}  // namespace texsynth
