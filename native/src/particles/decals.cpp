// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/particles/decals.hpp"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <bitset>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include "texsynth/common/errors.hpp"

namespace texsynth {
namespace {

constexpr double kPi = 3.14159265358979323846;
// R × κ above which a decal is flagged curved (squash > 4 %: docs/algorithms/texture_particles.md,
// "Decals and the analysis cache").
constexpr double kCurvedLimit = 0.5;
constexpr double kMinAreaFraction = 1e-12;  // of the rectangle: a clip with less area only touches it
constexpr int kMaxClip = 8;                 // a triangle clipped by 4 half-planes has at most 7 corners

// Rectangle sides as half-planes: 0 u >= u0, 1 v >= v0, 2 u <= u1, 3 v <= v1.
double side_distance(const std::array<double, 4>& r, int side, double u, double v) {
  switch (side) {
    case 0: return u - r[0];
    case 1: return v - r[1];
    case 2: return r[2] - u;
    default: return r[3] - v;
  }
}

// What a clip point is, for sharing it between the faces of one patch.
enum class PointKind : uint32_t { vertex = 0, edge_side = 1, corner = 2, unshared = 3 };

struct ClipPoint {
  double u = 0, v = 0;
  double b[3] = {0, 0, 0};  // barycentrics in the face being clipped
  uint8_t edges = 0;        // face edges (corner k -> k + 1) it lies on
  uint8_t sides = 0;        // rectangle sides it lies on
  uint64_t key_hi = 0, key_lo = 0;
};

uint64_t key_hi(PointKind kind, uint32_t a) { return (uint64_t(kind) << 32) | a; }

struct Key {
  uint64_t hi, lo;
  bool operator==(const Key& o) const { return hi == o.hi && lo == o.lo; }
};
struct KeyHash {
  size_t operator()(const Key& k) const { return size_t((k.hi * 0x9E3779B97F4A7C15ull) ^ (k.lo + (k.lo << 17) + 0x632BE59BD9B4E019ull)); }
};

// One face projected into the particle's (u, v) plane.
struct ProjectedFace {
  int32_t t = -1;
  int32_t weld[3] = {0, 0, 0};
  double u[3] = {0, 0, 0}, v[3] = {0, 0, 0};
};

class FaceClipper {
 public:
  FaceClipper(const std::array<double, 4>& rect, uint64_t& unshared_counter) : rect_(rect), unshared_(unshared_counter) {}

  // The face clipped to the rectangle; returns the number of corners (0 when less than 3).
  int clip(const ProjectedFace& f, ClipPoint* out) {
    f_ = &f;
    ClipPoint a[kMaxClip], b[kMaxClip];
    int n = 3;
    for (int k = 0; k < 3; ++k) {
      ClipPoint& p = a[k];
      p.u = f.u[k], p.v = f.v[k];
      p.b[k] = 1;
      p.edges = uint8_t((1 << k) | (1 << ((k + 2) % 3)));
      p.key_hi = key_hi(PointKind::vertex, uint32_t(f.weld[k]));
    }
    ClipPoint* in = a;
    ClipPoint* next = b;
    for (int side = 0; side < 4 && n > 0; ++side) {
      int m = 0;
      for (int i = 0; i < n; ++i) {
        ClipPoint& p = in[(i + n - 1) % n];
        ClipPoint& q = in[i];
        const double dp = side_distance(rect_, side, p.u, p.v), dq = side_distance(rect_, side, q.u, q.v);
        // Strict sign change only: a corner exactly on the side is kept as itself, never doubled.
        if ((dp > 0 && dq < 0) || (dp < 0 && dq > 0)) next[m++] = crossing(p, q, dp, dq, side);
        if (dq >= 0) {
          next[m] = q;
          if (dq == 0) next[m].sides |= uint8_t(1 << side);
          ++m;
        }
      }
      std::swap(in, next);
      n = m;
    }
    if (n < 3) return 0;
    std::copy(in, in + n, out);
    return n;
  }

 private:
  ClipPoint crossing(const ClipPoint& p, const ClipPoint& q, double dp, double dq, int side) {
    ClipPoint x;
    x.sides = uint8_t((p.sides & q.sides) | (1 << side));
    const uint8_t edge_mask = p.edges & q.edges;
    const uint8_t other_side = uint8_t(p.sides & q.sides & ~(1 << side));
    if (edge_mask) {
      // Along face edge e: computed from the edge's ends in weld order, so both faces of the edge
      // find the same point.
      const int e = edge_mask & 1 ? 0 : edge_mask & 2 ? 1 : 2;
      int lo = e, hi = (e + 1) % 3;
      if (f_->weld[hi] < f_->weld[lo]) std::swap(lo, hi);
      const double dlo = side_distance(rect_, side, f_->u[lo], f_->v[lo]);
      const double dhi = side_distance(rect_, side, f_->u[hi], f_->v[hi]);
      const double s = dlo / (dlo - dhi);
      x.u = f_->u[lo] + (f_->u[hi] - f_->u[lo]) * s;
      x.v = f_->v[lo] + (f_->v[hi] - f_->v[lo]) * s;
      x.b[lo] = 1 - s, x.b[hi] = s;
      x.edges = uint8_t(1 << e);
      x.key_hi = key_hi(PointKind::edge_side, uint32_t(side));
      x.key_lo = (uint64_t(uint32_t(f_->weld[lo])) << 32) | uint32_t(f_->weld[hi]);
    } else if (other_side) {
      // Along the rectangle side `other`: the rectangle's corner, placed by the face's barycentrics.
      const int other = other_side & 1 ? 0 : other_side & 2 ? 1 : other_side & 4 ? 2 : 3;
      const int us = side % 2 == 0 ? side : other, vs = side % 2 == 0 ? other : side;
      x.u = us == 0 ? rect_[0] : rect_[2];
      x.v = vs == 1 ? rect_[1] : rect_[3];
      barycentrics(x);
      x.key_hi = key_hi(PointKind::corner, uint32_t((us == 2 ? 1 : 0) | (vs == 3 ? 2 : 0)));
    } else {
      // Not reached for clips of a triangle (every segment runs along an edge or a side); kept safe.
      const double s = dp / (dp - dq);
      x.u = p.u + (q.u - p.u) * s, x.v = p.v + (q.v - p.v) * s;
      for (int k = 0; k < 3; ++k) x.b[k] = p.b[k] + (q.b[k] - p.b[k]) * s;
      x.key_hi = key_hi(PointKind::unshared, 0);
      x.key_lo = unshared_++;
    }
    // On the side exactly: UVs land on the atlas cell's border, never beyond it.
    if (side == 0) x.u = rect_[0];
    if (side == 1) x.v = rect_[1];
    if (side == 2) x.u = rect_[2];
    if (side == 3) x.v = rect_[3];
    return x;
  }

  void barycentrics(ClipPoint& x) const {
    const ProjectedFace& f = *f_;
    const double e1u = f.u[1] - f.u[0], e1v = f.v[1] - f.v[0], e2u = f.u[2] - f.u[0], e2v = f.v[2] - f.v[0];
    const double qu = x.u - f.u[0], qv = x.v - f.v[0];
    const double det = e1u * e2v - e1v * e2u;
    double b1 = det != 0 ? (qu * e2v - qv * e2u) / det : 0, b2 = det != 0 ? (e1u * qv - e1v * qu) / det : 0;
    b1 = std::clamp(b1, 0.0, 1.0), b2 = std::clamp(b2, 0.0, 1.0);
    if (b1 + b2 > 1) {
      const double s = b1 + b2;
      b1 /= s, b2 /= s;
    }
    x.b[0] = 1 - b1 - b2, x.b[1] = b1, x.b[2] = b2;
  }

  const std::array<double, 4>& rect_;
  uint64_t& unshared_;
  const ProjectedFace* f_ = nullptr;
};

double polygon_area(const ClipPoint* p, int n) {
  double a = 0;
  for (int i = 0; i < n; ++i) {
    const ClipPoint& c = p[i];
    const ClipPoint& d = p[(i + 1) % n];
    a += c.u * d.v - d.u * c.v;
  }
  return 0.5 * a;
}

// One particle's decal, local vertex numbering.
struct Patch {
  std::vector<float> positions;  // 3 per vertex
  std::vector<float> uvs;        // 2 per vertex (atlas)
  std::vector<int32_t> sizes;    // corners per polygon
  std::vector<int32_t> corners;  // local vertex ids
  std::vector<int32_t> triangles;  // per polygon: the target triangle it lies in
  std::vector<float> barycentric;  // 2 per corner: (b1, b2) on that triangle (a vertex shared by faces has one per face)
  bool curved = false, capped = false;
  int64_t visited = 0, folded = 0;
  double coverage = 0;
};

// Per-thread scratch reused across particles; the patch is built in the buffers of a Patch's names.
struct Scratch {
  std::vector<float> positions, uvs;
  std::vector<int32_t> sizes, corners, triangles;
  std::vector<float> barycentric;
  std::vector<uint32_t> stamp;  // per triangle: particle + 1 that queued it
  std::vector<int32_t> queue;
  std::unordered_map<Key, int32_t, KeyHash> vertex_of;
  std::vector<double> normal_cos, distance;  // per local vertex, for the curvature estimate
};

float atlas(double s0, double s1, double f) { return float(s0 * (1 - f) + s1 * f); }

// A particle's rectangle as it lies on the surface: the anchor, its smooth normal and tangent frame, and the
// corners in that frame. Computed once per particle, for the stacking and the patch.
struct Footprint {
  V3 centre, normal, u, v;
  std::array<double, 4> rect{};
  double radius = 0;  // the farthest corner: a sphere round the centre holds the whole rectangle
};

Footprint footprint_of(const WalkMesh& walk, const TriangleMeshInput& in, const DecalParticle& p) {
  Footprint f;
  f.centre = surface_position(in, p.anchor);
  f.normal = smooth_normal(walk, in, p.anchor);
  f.u = normalized_or(project_to_plane(p.axis, f.normal), any_perpendicular(f.normal));
  f.v = cross(f.normal, f.u);
  f.rect = p.rect;
  const auto& r = p.rect;
  f.radius = std::sqrt(std::max(r[0] * r[0], r[2] * r[2]) + std::max(r[1] * r[1], r[3] * r[3]));
  return f;
}

Patch build_patch(const SurfaceWalkMesh& mesh, const TriangleMeshInput& in, const DecalParticle& p,
                  const Footprint& foot, uint32_t stamp, const DecalOptions& o, double lift, double cos_max,
                  Scratch& sc) {
  Patch out;
  const WalkMesh& walk = mesh.walk;
  const int32_t t0 = p.anchor.triangle;
  if (walk.tris[size_t(t0)].degenerate) return out;
  const V3 x0 = foot.centre, n0 = foot.normal, u = foot.u, v = foot.v;
  const auto& r = p.rect;
  const double rect_area = (r[2] - r[0]) * (r[3] - r[1]);
  const double radius = foot.radius;

  uint64_t unshared = 0;
  FaceClipper clipper(r, unshared);
  sc.vertex_of.clear();
  sc.positions.clear(), sc.uvs.clear(), sc.sizes.clear(), sc.corners.clear();
  sc.triangles.clear(), sc.barycentric.clear();
  sc.normal_cos.clear(), sc.distance.clear();
  sc.queue.clear();
  sc.queue.push_back(t0);
  sc.stamp[size_t(t0)] = stamp;
  int32_t included = 0;
  double area = 0;
  ClipPoint poly[kMaxClip];
  for (size_t head = 0; head < sc.queue.size(); ++head) {
    const int32_t t = sc.queue[head];
    const WalkTriangle& wt = walk.tris[size_t(t)];
    ++out.visited;
    // The anchor's own face only needs to face the same way (the smooth normal may lean on coarse meshes).
    if (dot(wt.normal, n0) < (t == t0 ? 0.0 : cos_max)) {
      ++out.folded;
      continue;
    }
    ProjectedFace f;
    f.t = t;
    const int32_t* c = in.triangles + 3 * size_t(t);
    for (int k = 0; k < 3; ++k) {
      f.weld[k] = walk.weld[size_t(c[k])];
      const V3 d = mesh_position(in, c[k]) - x0;
      f.u[k] = dot(d, u), f.v[k] = dot(d, v);
    }
    const int n = clipper.clip(f, poly);
    const double a = n ? polygon_area(poly, n) : 0;
    if (!(a > kMinAreaFraction * rect_area)) continue;  // outside the rectangle (or only touching it)
    area += a;
    int32_t size = 0;
    for (int i = 0; i < n; ++i) {
      const ClipPoint& q = poly[i];
      auto [it, added] = sc.vertex_of.emplace(Key{q.key_hi, q.key_lo}, int32_t(sc.positions.size() / 3));
      if (added) {
        const SurfacePoint sp{t, q.b[1], q.b[2]};
        const V3 at = mesh_position(in, c[0]) * q.b[0] + mesh_position(in, c[1]) * q.b[1] + mesh_position(in, c[2]) * q.b[2];
        const V3 n_at = smooth_normal(walk, in, sp);
        const V3 pos = at + n_at * lift;
        sc.positions.insert(sc.positions.end(), {float(pos.x), float(pos.y), float(pos.z)});
        const double fu = std::clamp((q.u - r[0]) / (r[2] - r[0]), 0.0, 1.0);
        const double fv = std::clamp((q.v - r[1]) / (r[3] - r[1]), 0.0, 1.0);
        sc.uvs.insert(sc.uvs.end(), {atlas(p.uv_rect[0], p.uv_rect[2], fu), atlas(p.uv_rect[1], p.uv_rect[3], fv)});
        sc.normal_cos.push_back(dot(n_at, n0));
        sc.distance.push_back(norm(at - x0));
      }
      // Two clip points with one key in a row (a degenerate touch) make one corner.
      if (size > 0 && sc.corners.back() == it->second) continue;
      sc.corners.push_back(it->second);
      sc.barycentric.insert(sc.barycentric.end(), {float(q.b[1]), float(q.b[2])});
      ++size;
    }
    if (size > 1 && sc.corners.back() == sc.corners[sc.corners.size() - size_t(size)]) {
      sc.corners.pop_back(), --size;
      sc.barycentric.resize(sc.barycentric.size() - 2);
    }
    if (size < 3) {
      sc.corners.resize(sc.corners.size() - size_t(size));
      sc.barycentric.resize(sc.barycentric.size() - 2 * size_t(size));
      continue;
    }
    sc.sizes.push_back(size);
    sc.triangles.push_back(t);
    if (++included >= o.max_faces_per_particle) {
      out.capped = true;
      break;
    }
    for (int k = 0; k < 3; ++k) {
      const int32_t across = wt.across[size_t(k)];
      if (across < 0) continue;
      const int32_t nt = across >> 2;
      if (sc.stamp[size_t(nt)] == stamp) continue;
      sc.stamp[size_t(nt)] = stamp;
      sc.queue.push_back(nt);
    }
  }
  out.coverage = rect_area > 0 ? area / rect_area : 0;
  double curvature = 0;
  for (size_t i = 0; i < sc.distance.size(); ++i)
    if (sc.distance[i] >= 0.25 * radius && sc.distance[i] > 0)
      curvature = std::max(curvature, std::acos(std::clamp(sc.normal_cos[i], -1.0, 1.0)) / sc.distance[i]);
  out.curved = radius * curvature > kCurvedLimit;
  out.positions.assign(sc.positions.begin(), sc.positions.end());  // exact sizes: one allocation each
  out.uvs.assign(sc.uvs.begin(), sc.uvs.end());
  out.sizes.assign(sc.sizes.begin(), sc.sizes.end());
  out.corners.assign(sc.corners.begin(), sc.corners.end());
  out.triangles.assign(sc.triangles.begin(), sc.triangles.end());
  out.barycentric.assign(sc.barycentric.begin(), sc.barycentric.end());
  return out;
}

bool finite(V3 a) { return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z); }

std::string item(const char* what, int64_t i) { return std::string("decal mesh: ") + what + " of particle " + std::to_string(i); }

// Checks every particle; returns them with anchors clamped into their triangles.
std::vector<DecalParticle> checked_particles(const SurfaceWalkMesh& mesh, const DecalParticle* particles, int64_t count) {
  const int32_t num_triangles = int32_t(mesh.triangles.size() / 3);
  std::vector<DecalParticle> out(particles, particles + count);
  for (int64_t i = 0; i < count; ++i) {
    DecalParticle& p = out[size_t(i)];
    p.anchor = checked_surface_point(p.anchor, num_triangles, "decal mesh", "particle", i);
    const V3 n = smooth_normal(mesh.walk, mesh.input(), p.anchor);
    const double len = norm(p.axis);
    if (!finite(p.axis) || !(len > 0) || !(norm(project_to_plane(p.axis, n)) > 1e-6 * len))
      throw std::invalid_argument(item("axis", i) + " is NaN, zero or along the surface normal");
    const auto& r = p.rect;
    for (double x : r)
      if (!std::isfinite(x)) throw std::invalid_argument(item("rect", i) + " is NaN or infinite");
    if (!(r[0] < r[2]) || !(r[1] < r[3])) {
      std::ostringstream msg;
      msg << item("rect", i) << " (" << r[0] << ", " << r[1] << ", " << r[2] << ", " << r[3]
          << ") is empty or negative (needs u0 < u1 and v0 < v1)";
      throw std::invalid_argument(msg.str());
    }
    if (r[0] > 0 || r[2] < 0 || r[1] > 0 || r[3] < 0)
      throw std::invalid_argument(item("rect", i) + " does not contain the anchor (needs u0 <= 0 <= u1, v0 <= 0 <= v1)");
    for (double x : p.uv_rect)
      if (!std::isfinite(x)) throw std::invalid_argument(item("uv_rect", i) + " is NaN or infinite");
  }
  return out;
}

// Rectangles k and j overlap in k's tangent plane (j's corners projected there): no separating axis among the
// four edge normals. Neighbouring decals lie on nearly one plane, so the projection is close to the surface.
bool footprints_overlap(const Footprint& k, const Footprint& j) {
  std::array<std::array<double, 2>, 4> a, b;
  const auto& rk = k.rect;
  a = {{{rk[0], rk[1]}, {rk[2], rk[1]}, {rk[2], rk[3]}, {rk[0], rk[3]}}};
  const auto& rj = j.rect;
  const std::array<std::array<double, 2>, 4> local = {{{rj[0], rj[1]}, {rj[2], rj[1]}, {rj[2], rj[3]}, {rj[0], rj[3]}}};
  for (int c = 0; c < 4; ++c) {
    const V3 p = j.centre + j.u * local[size_t(c)][0] + j.v * local[size_t(c)][1] - k.centre;
    b[size_t(c)] = {dot(p, k.u), dot(p, k.v)};
  }
  auto separated_along_edges_of = [](const auto& poly, const auto& other) {
    for (int e = 0; e < 4; ++e) {
      const auto& p0 = poly[size_t(e)];
      const auto& p1 = poly[size_t((e + 1) % 4)];
      const double nx = p1[1] - p0[1], ny = p0[0] - p1[0];
      double lo_a = 1e300, hi_a = -1e300, lo_b = 1e300, hi_b = -1e300;
      for (int q = 0; q < 4; ++q) {
        const double pa = nx * poly[size_t(q)][0] + ny * poly[size_t(q)][1];
        const double pb = nx * other[size_t(q)][0] + ny * other[size_t(q)][1];
        lo_a = std::min(lo_a, pa), hi_a = std::max(hi_a, pa), lo_b = std::min(lo_b, pb), hi_b = std::max(hi_b, pb);
      }
      if (hi_a <= lo_b || hi_b <= lo_a) return true;
    }
    return false;
  };
  return !separated_along_edges_of(a, b) && !separated_along_edges_of(b, a);
}

// Stacking levels (DecalOptions::stack_step), a greedy colouring: in particle order, each takes the lowest level
// no earlier particle whose rectangle overlaps its own has taken (the cap when all are taken). So overlapping
// decals lie at different heights, and the levels stay as few as the overlaps are deep (a "lower-numbered on
// top" order would climb one level per link of a chain of overlaps: 9 levels for packed pebbles on a bunny,
// where this colouring needs 5). Earlier particles are kept in a uniform grid of cells one widest footprint
// across, so only the 27 cells round a particle can hold an overlap. One huge footprint among small ones
// makes the cells huge: the pair tests are bounded (kStackTestsPerParticle per particle on average), and
// the particles after the bound keep level 0 (counted in DecalStats::unstacked).
constexpr int64_t kStackTestsPerParticle = 256;

std::vector<int32_t> stack_levels(const std::vector<Footprint>& foot, int32_t cap, int64_t* unstacked) {
  const size_t n = foot.size();
  std::vector<int32_t> level(n, 0);
  double widest = 0;
  for (const Footprint& f : foot) widest = std::max(widest, f.radius);
  if (n < 2 || !(widest > 0)) return level;
  const double cell = 2 * widest;
  // Clamped before the cast: a tiny footprint far from the origin gives a quotient beyond int64.
  auto cell_of = [&](double x) { return int64_t(std::clamp(std::floor(x / cell), -1e15, 1e15)); };
  int64_t budget = kStackTestsPerParticle * int64_t(n);
  auto key = [](int64_t x, int64_t y, int64_t z) {  // 21 bits per axis: cells beyond wrap, costing checks only
    return (uint64_t(x) & 0x1FFFFF) | (uint64_t(y) & 0x1FFFFF) << 21 | (uint64_t(z) & 0x1FFFFF) << 42;
  };
  std::unordered_map<uint64_t, std::vector<int32_t>> grid;
  std::bitset<kMaxDecalStackLevel + 1> taken;
  for (size_t k = 0; k < n; ++k) {
    if (budget <= 0) {
      *unstacked = int64_t(n - k);
      break;
    }
    const Footprint& f = foot[k];
    const int64_t cx = cell_of(f.centre.x), cy = cell_of(f.centre.y), cz = cell_of(f.centre.z);
    taken.reset();
    for (int64_t dx = -1; dx <= 1; ++dx)
      for (int64_t dy = -1; dy <= 1; ++dy)
        for (int64_t dz = -1; dz <= 1; ++dz) {
          const auto found = grid.find(key(cx + dx, cy + dy, cz + dz));
          if (found == grid.end()) continue;
          budget -= int64_t(found->second.size());
          for (int32_t j : found->second) {
            const Footprint& g = foot[size_t(j)];
            if (taken[size_t(level[size_t(j)])] || !(norm(g.centre - f.centre) < f.radius + g.radius)) continue;
            if (footprints_overlap(f, g)) taken[size_t(level[size_t(j)])] = true;
          }
        }
    int32_t free = 0;
    while (free < cap && taken[size_t(free)]) ++free;
    level[k] = free;
    grid[key(cx, cy, cz)].push_back(int32_t(k));
  }
  return level;
}

}  // namespace

DecalMesh build_decal_mesh(const SurfaceWalkMesh& mesh, const DecalParticle* particles, int64_t count,
                           const DecalOptions& o) {
  const auto start = std::chrono::steady_clock::now();
  if (count < 0 || (count > 0 && !particles)) throw std::invalid_argument("decal mesh: missing particles");
  if (count >= int64_t(std::numeric_limits<uint32_t>::max()))
    throw std::invalid_argument("decal mesh: too many particles (" + std::to_string(count) + ")");
  if (!std::isfinite(o.offset)) throw std::invalid_argument("decal mesh: offset must be finite");
  if (!std::isfinite(o.stack_step) || o.stack_step < 0)
    throw std::invalid_argument("decal mesh: stack_step must be finite and >= 0");
  if (o.max_level < 0 || o.max_level > kMaxDecalStackLevel)
    throw std::invalid_argument("decal mesh: max_level must be 0.." + std::to_string(kMaxDecalStackLevel));
  if (!std::isfinite(o.max_normal_angle) || !(o.max_normal_angle > 0) || !(o.max_normal_angle < 90))
    throw std::invalid_argument("decal mesh: max_normal_angle must be in (0, 90) degrees");
  if (o.max_faces_per_particle < 1) throw std::invalid_argument("decal mesh: max_faces_per_particle must be >= 1");
  if (mesh.walk.tris.size() != mesh.triangles.size() / 3 || mesh.triangles.empty())
    throw std::invalid_argument("decal mesh: the walk mesh is empty or inconsistent");
  const std::vector<DecalParticle> in = checked_particles(mesh, particles, count);
  throw_if_cancelled(o.cancel);

  const TriangleMeshInput input = mesh.input();
  const double cos_max = std::cos(o.max_normal_angle * kPi / 180);
  int64_t unstacked = 0;
  std::vector<Footprint> foot(static_cast<size_t>(count));
  tbb::parallel_for(tbb::blocked_range<int64_t>(0, count, 256), [&](const tbb::blocked_range<int64_t>& range) {
    for (int64_t i = range.begin(); i < range.end(); ++i) foot[size_t(i)] = footprint_of(mesh.walk, input, in[size_t(i)]);
  });
  const std::vector<int32_t> level = o.stack_step > 0 ? stack_levels(foot, o.max_level, &unstacked)
                                                      : std::vector<int32_t>(size_t(count), 0);
  throw_if_cancelled(o.cancel);
  std::vector<Patch> patches(static_cast<size_t>(count));
  tbb::enumerable_thread_specific<Scratch> scratch([&] {
    Scratch s;
    s.stamp.assign(mesh.walk.tris.size(), 0);
    return s;
  });
  // Visited by anchor face (neighbouring faces are mostly near in memory): 2x fewer cache misses on
  // randomly ordered particles. Each patch depends on its particle only, so the order changes no byte.
  std::vector<int64_t> order(static_cast<size_t>(count));
  for (int64_t i = 0; i < count; ++i) order[size_t(i)] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&](int64_t a, int64_t b) { return in[size_t(a)].anchor.triangle < in[size_t(b)].anchor.triangle; });
  tbb::parallel_for(tbb::blocked_range<int64_t>(0, count, 16), [&](const tbb::blocked_range<int64_t>& range) {
    throw_if_cancelled(o.cancel);
    Scratch& sc = scratch.local();
    for (int64_t k = range.begin(); k < range.end(); ++k) {
      const int64_t i = order[size_t(k)];
      const double lift = o.offset + double(level[size_t(i)]) * o.stack_step;
      patches[size_t(i)] = build_patch(mesh, input, in[size_t(i)], foot[size_t(i)], uint32_t(i + 1), o, lift,
                                             cos_max, sc);
    }
  });
  throw_if_cancelled(o.cancel);

  // Concatenation in particle order: offsets first, then every patch copied into its slot.
  std::vector<int64_t> vert_at(size_t(count) + 1, 0), poly_at(size_t(count) + 1, 0), corner_at(size_t(count) + 1, 0);
  DecalMesh out;
  DecalStats& s = out.stats;
  s.particles = count;
  s.min_coverage = count ? std::numeric_limits<double>::infinity() : 0;
  for (int64_t i = 0; i < count; ++i) {
    const Patch& p = patches[size_t(i)];
    vert_at[size_t(i) + 1] = vert_at[size_t(i)] + int64_t(p.positions.size() / 3);
    poly_at[size_t(i) + 1] = poly_at[size_t(i)] + int64_t(p.sizes.size());
    corner_at[size_t(i) + 1] = corner_at[size_t(i)] + int64_t(p.corners.size());
    s.empty += p.sizes.empty(), s.capped += p.capped, s.curved += p.curved;
    s.faces_visited += p.visited, s.faces_folded += p.folded;
    s.min_coverage = std::min(s.min_coverage, p.coverage);
    s.overlapping += p.coverage > 1 + 1e-9;
    s.mean_coverage += p.coverage;
    s.stacked += level[size_t(i)] > 0;
    s.unstacked = unstacked;
    s.max_level = std::max(s.max_level, level[size_t(i)]);
  }
  if (count) s.mean_coverage /= double(count);
  const int64_t V = vert_at.back(), F = poly_at.back(), C = corner_at.back();
  if (C > std::numeric_limits<int32_t>::max() || V > std::numeric_limits<int32_t>::max())
    throw std::invalid_argument("decal mesh: the result would have more than 2^31 - 1 corners (" + std::to_string(C) + ")");
  out.positions.resize(size_t(V) * 3);
  out.loop_starts.resize(size_t(F));
  out.loop_totals.resize(size_t(F));
  out.face_particle.resize(size_t(F));
  out.face_triangle.resize(size_t(F));
  out.corner_barycentric.resize(size_t(C) * 2);
  out.corner_verts.resize(size_t(C));
  out.corner_uvs.resize(size_t(C) * 2);
  out.curved.resize(size_t(count));
  out.level = level;
  tbb::parallel_for(tbb::blocked_range<int64_t>(0, count, 64), [&](const tbb::blocked_range<int64_t>& range) {
    for (int64_t i = range.begin(); i < range.end(); ++i) {
      const Patch& p = patches[size_t(i)];
      std::copy(p.positions.begin(), p.positions.end(), out.positions.begin() + 3 * vert_at[size_t(i)]);
      int64_t corner = corner_at[size_t(i)];
      for (size_t f = 0; f < p.sizes.size(); ++f) {
        const size_t at = size_t(poly_at[size_t(i)]) + f;
        out.loop_starts[at] = int32_t(corner);
        out.loop_totals[at] = p.sizes[f];
        out.face_particle[at] = int32_t(i);
        out.face_triangle[at] = p.triangles[f];
        corner += p.sizes[f];
      }
      for (size_t k = 0; k < p.corners.size(); ++k) {
        const size_t at = size_t(corner_at[size_t(i)]) + k;
        const int32_t local = p.corners[k];
        out.corner_verts[at] = int32_t(vert_at[size_t(i)] + local);
        out.corner_uvs[2 * at] = p.uvs[2 * size_t(local)];
        out.corner_uvs[2 * at + 1] = p.uvs[2 * size_t(local) + 1];
      }
      std::copy(p.barycentric.begin(), p.barycentric.end(), out.corner_barycentric.begin() + 2 * corner_at[size_t(i)]);
      out.curved[size_t(i)] = p.curved;
    }
  });
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace texsynth
