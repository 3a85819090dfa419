// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/particles/surface_walk.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

#include "texsynth/common/errors.hpp"

namespace texsynth {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNudge = 1e-7;               // × the start face's longest edge (texture_particles.md, "Surface walks")
constexpr double kReachTolerance = 1e-6;      // × the same edge: the section passes through P2
constexpr double kParallel = 1e-9;            // |P1P2 × N1| below this × |P1P2|: no plane
constexpr double kBarycentricTolerance = 1e-4;

struct Face {
  V3 p[3];
};
Face face(const TriangleMeshInput& m, int32_t t) {
  const int32_t* c = m.triangles + 3 * size_t(t);
  return {{mesh_position(m, c[0]), mesh_position(m, c[1]), mesh_position(m, c[2])}};
}

// The cutting plane and its nudge: a corner within |eps| of the plane counts as lying at eps. The
// value depends on the corner's position only (welded corners are bit-equal), so every face around a
// vertex agrees on its side and the polyline stays connected.
struct Plane {
  V3 n, origin;
  double eps;
  double side(V3 p) const {
    const double s = dot(n, p - origin);
    return std::fabs(s) < std::fabs(eps) ? eps : s;
  }
};

// Where the walk stands after a face: the exit crossing (triangle, edge, barycentrics, position).
struct WalkState {
  int32_t t = -1;
  int edge = -1;
  double exit_b[3] = {0, 0, 0};
  V3 exit;
  V3 dir;
  double walked = 0;
  int32_t faces = 0;
  double exit_side[2] = {0, 0};  // plane sides of the exit edge's corners (edge, edge + 1)
};

// The crossing of edge k -> k+1 (sides sa, sb of opposite signs): λ along the edge.
double crossing(double sa, double sb) { return sa / (sa - sb); }

// Walks the section of `plane` from `start` (on the plane), leaving the start face ahead along
// `forward`. `visit(t, a_b, a, e_b, e, seg, walked_before)` sees each face's segment (entry a -> exit
// e, barycentrics in t) and returns true to stop there (status reached). Walls, the face cap and the
// length cap end the walk with `st` at the last exit crossing.
template <class Visit>
WalkStatus walk_plane(const WalkMesh& w, const TriangleMeshInput& m, const SurfacePoint& start, Plane plane, V3 forward,
                      double length_cap, int32_t max_faces, Visit&& visit, WalkState& st) {
  const int32_t t0 = start.triangle;
  const Face f0 = face(m, t0);
  const double b0[3] = {1 - start.b1 - start.b2, start.b1, start.b2};
  const V3 x0 = plane.origin;
  // Start face: of the two edges the plane crosses, the one ahead. A start within eps of a corner may
  // see no crossing with the nudge one way; the other way it does (then the whole walk keeps it).
  int exit = -1;
  double lam = 0, s[3] = {0, 0, 0};
  V3 q;
  for (int attempt = 0; attempt < 2 && exit < 0; ++attempt) {
    if (attempt) plane.eps = -plane.eps;
    for (int k = 0; k < 3; ++k) s[k] = plane.side(f0.p[k]);
    double best = -kInf;
    for (int k = 0; k < 3; ++k) {
      const int k1 = (k + 1) % 3;
      if ((s[k] > 0) == (s[k1] > 0)) continue;
      const double l = crossing(s[k], s[k1]);
      const V3 c = f0.p[k] + (f0.p[k1] - f0.p[k]) * l;
      const double ahead = dot(c - x0, forward);
      if (ahead > best) best = ahead, exit = k, lam = l, q = c;
    }
  }
  if (exit < 0) return WalkStatus::no_plane;
  st.t = t0;
  st.faces = 1;
  st.edge = exit;
  st.exit_b[exit] = 1 - lam, st.exit_b[(exit + 1) % 3] = lam, st.exit_b[(exit + 2) % 3] = 0;
  st.exit = q;
  st.exit_side[0] = s[exit], st.exit_side[1] = s[(exit + 1) % 3];
  double seg = norm(q - x0);
  st.dir = normalized_or(q - x0, forward);
  if (visit(t0, b0, x0, st.exit_b, q, seg, 0.0)) return WalkStatus::reached;
  st.walked = seg;

  for (;;) {
    const int32_t across = w.tris[st.t].across[st.edge];
    if (across < 0) return WalkStatus::wall;
    if (st.faces >= max_faces) return WalkStatus::face_limit;
    if (st.walked > length_cap) return WalkStatus::length_limit;
    const int32_t nt = across >> 2;
    const int ne = across & 3, ne1 = (ne + 1) % 3, o = (ne + 2) % 3;
    // Consistent orientation: the shared edge runs the other way here (nt's corner ne is the previous
    // face's corner edge + 1), so the entry's barycentrics and sides carry over without recomputation.
    double sn[3];
    sn[ne] = st.exit_side[1], sn[ne1] = st.exit_side[0];
    double entry_b[3];
    entry_b[ne] = st.exit_b[(st.edge + 1) % 3], entry_b[ne1] = st.exit_b[st.edge], entry_b[o] = 0;
    const V3 a = st.exit;
    const int32_t* c = m.triangles + 3 * size_t(nt);
    const V3 po = mesh_position(m, c[o]);
    sn[o] = plane.side(po);
    // The exit: the other edge whose corners lie on opposite sides.
    const int e = (sn[o] > 0) != (sn[ne] > 0) ? o : ne1;
    const int e1 = (e + 1) % 3;
    const double l = crossing(sn[e], sn[e1]);
    const V3 pe = mesh_position(m, c[e]), pe1 = mesh_position(m, c[e1]);
    const V3 x = pe + (pe1 - pe) * l;
    double exit_b[3];
    exit_b[e] = 1 - l, exit_b[e1] = l, exit_b[(e + 2) % 3] = 0;
    seg = norm(x - a);
    if (seg > 0) st.dir = (x - a) * (1.0 / seg);
    ++st.faces;
    st.t = nt;
    st.edge = e;
    std::copy(exit_b, exit_b + 3, st.exit_b);
    st.exit = x;
    st.exit_side[0] = sn[e], st.exit_side[1] = sn[e1];
    if (visit(nt, entry_b, a, exit_b, x, seg, st.walked)) return WalkStatus::reached;
    st.walked += seg;
  }
}

double longest_edge(const Face& f) {
  return std::sqrt(std::max({dot(f.p[1] - f.p[0], f.p[1] - f.p[0]), dot(f.p[2] - f.p[1], f.p[2] - f.p[1]),
                             dot(f.p[0] - f.p[2], f.p[0] - f.p[2])}));
}

SurfacePoint to_point(int32_t t, const double b[3]) { return {t, b[1], b[2]}; }

}  // namespace

V3 surface_position(const TriangleMeshInput& mesh, const SurfacePoint& p) {
  const Face f = face(mesh, p.triangle);
  return f.p[0] * (1 - p.b1 - p.b2) + f.p[1] * p.b1 + f.p[2] * p.b2;
}

V3 smooth_normal(const WalkMesh& walk, const TriangleMeshInput& mesh, const SurfacePoint& p) {
  const int32_t* c = mesh.triangles + 3 * size_t(p.triangle);
  const V3 n = walk.vertex_normal[walk.weld[c[0]]] * (1 - p.b1 - p.b2) + walk.vertex_normal[walk.weld[c[1]]] * p.b1 +
               walk.vertex_normal[walk.weld[c[2]]] * p.b2;
  const V3 face_normal = walk.tris[p.triangle].normal;
  // Vertex normals of a two-sided sheet cancel to rounding noise of either sign: a smooth normal that
  // faces away from its own face means nothing there, so each side keeps its face's.
  const V3 s = normalized_or(n, face_normal, 1e-6);
  return dot(s, face_normal) > 0 ? s : face_normal;
}

SectionWalkResult walk_normal_section(const WalkMesh& walk, const TriangleMeshInput& mesh, const SurfacePoint& start,
                                      V3 direction, double length, const SectionWalkOptions& options) {
  SectionWalkResult r;
  r.end = start;
  r.position = surface_position(mesh, start);
  const WalkTriangle& wt = walk.tris[start.triangle];
  if (wt.degenerate) return r;
  const V3 d = normalized_or(project_to_plane(direction, wt.normal), V3{}, 1e-9 * norm(direction));
  const V3 n = normalized_or(cross(d, smooth_normal(walk, mesh, start)), V3{}, 1e-9);
  if (norm(d) == 0 || norm(n) == 0) return r;
  const Plane plane{n, r.position, kNudge * longest_edge(face(mesh, start.triangle))};
  bool done = false;
  WalkState st;
  auto visit = [&](int32_t t, const double* ab, V3 a, const double* eb, V3 e, double seg, double before) {
    if (before + seg < length) return false;
    const double f = seg > 0 ? (length - before) / seg : 0;
    double b[3];
    for (int k = 0; k < 3; ++k) b[k] = ab[k] + (eb[k] - ab[k]) * f;
    r.end = to_point(t, b);
    r.position = a + (e - a) * f;
    done = true;
    return true;
  };
  r.status = walk_plane(walk, mesh, start, plane, d, kInf, options.max_faces, visit, st);
  if (r.status == WalkStatus::no_plane) return r;
  r.faces = st.faces;
  r.direction = st.dir;
  if (done) {
    r.length = length;
  } else {
    r.end = to_point(st.t, st.exit_b);
    r.position = st.exit;
    r.length = st.walked;
  }
  return r;
}

double pseudo_geodesic_distance_oneway(const WalkMesh& walk, const TriangleMeshInput& mesh, const SurfacePoint& p1,
                                       const SurfacePoint& p2, const SectionWalkOptions& options) {
  const V3 x1 = surface_position(mesh, p1), x2 = surface_position(mesh, p2), v = x2 - x1;
  const double chord = norm(v);
  if (chord == 0) return 0;
  if (walk.tris[p1.triangle].degenerate) return kInf;
  // One flat face holds the plane's whole trace through both points: the segment itself.
  if (p1.triangle == p2.triangle) return chord;
  const V3 n = cross(v, smooth_normal(walk, mesh, p1));
  if (!(norm(n) > kParallel * chord)) return kInf;  // P1P2 ∥ N1 (thin sheet): no plane
  const double edge = longest_edge(face(mesh, p1.triangle));
  const Plane plane{n * (1.0 / norm(n)), x1, kNudge * edge};
  const double reach2 = (kReachTolerance * edge) * (kReachTolerance * edge);
  double found = kInf;
  auto visit = [&](int32_t t, const double*, V3 a, const double*, V3 e, double seg, double before) {
    if (t == p2.triangle) {
      found = before + norm(x2 - a);
      return true;
    }
    // P2 on an edge or a vertex the nudged plane passes beside, without entering P2's face.
    const V3 ae = e - a;
    const double f = seg > 0 ? std::clamp(dot(x2 - a, ae) / (seg * seg), 0.0, 1.0) : 0.0;
    const V3 closest = a + ae * f;
    if (dot(x2 - closest, x2 - closest) <= reach2) {
      found = before + f * seg;
      return true;
    }
    return false;
  };
  WalkState st;
  const WalkStatus s =
      walk_plane(walk, mesh, p1, plane, v, options.max_length_factor * chord, options.max_faces, visit, st);
  return s == WalkStatus::reached && found <= options.max_length_factor * chord ? found : kInf;
}

PseudoGeodesic pseudo_geodesic_distance(const WalkMesh& walk, const TriangleMeshInput& mesh, const SurfacePoint& p1,
                                        const SurfacePoint& p2, const SectionWalkOptions& options) {
  if (dot(smooth_normal(walk, mesh, p1), smooth_normal(walk, mesh, p2)) < 0) return {kInf, DistanceKind::opposite_normals};
  const double d12 = pseudo_geodesic_distance_oneway(walk, mesh, p1, p2, options);
  const double d21 = pseudo_geodesic_distance_oneway(walk, mesh, p2, p1, options);
  if (d12 == kInf && d21 == kInf) return {norm(surface_position(mesh, p2) - surface_position(mesh, p1)), DistanceKind::chord};
  return d21 < d12 ? PseudoGeodesic{d21, DistanceKind::reverse_section} : PseudoGeodesic{d12, DistanceKind::section};
}

namespace {

void validate_options(const SectionWalkOptions& o, const char* who) {
  if (o.max_faces < 1) throw std::invalid_argument(std::string(who) + ": max_faces must be >= 1");
  if (!std::isfinite(o.max_length_factor) || o.max_length_factor < 1)
    throw std::invalid_argument(std::string(who) + ": max_length_factor must be finite and >= 1");
}


template <class Body>
void parallel_items(int64_t count, const std::atomic<bool>* cancel, Body&& body) {
  tbb::parallel_for(tbb::blocked_range<int64_t>(0, count, 64), [&](const tbb::blocked_range<int64_t>& r) {
    throw_if_cancelled(cancel);
    for (int64_t i = r.begin(); i < r.end(); ++i) body(i);
  });
}

}  // namespace

SurfacePoint checked_surface_point(const SurfacePoint& p, int32_t num_triangles, const char* who, const char* what, int64_t i) {
  if (p.triangle < 0 || p.triangle >= num_triangles)
    throw std::invalid_argument(std::string(who) + ": " + what + " " + std::to_string(i) + " is in triangle " +
                                std::to_string(p.triangle) + " (mesh has " + std::to_string(num_triangles) +
                                " triangles)");
  if (!std::isfinite(p.b1) || !std::isfinite(p.b2) || p.b1 < -kBarycentricTolerance || p.b2 < -kBarycentricTolerance ||
      p.b1 + p.b2 > 1 + kBarycentricTolerance) {
    std::ostringstream msg;
    msg << who << ": barycentrics of " << what << " " << i << " (" << p.b1 << ", " << p.b2
        << ") are NaN or not inside the triangle";
    throw std::invalid_argument(msg.str());
  }
  SurfacePoint c{p.triangle, std::max(p.b1, 0.0), std::max(p.b2, 0.0)};
  if (c.b1 + c.b2 > 1) {
    const double s = c.b1 + c.b2;
    c.b1 /= s, c.b2 /= s;
  }
  return c;
}

std::vector<SectionWalkResult> walk_normal_sections(const WalkMesh& walk, const TriangleMeshInput& mesh,
                                                    const SectionWalkRequest* walks, int64_t count,
                                                    const SectionWalkOptions& options,
                                                    const std::atomic<bool>* cancel) {
  const char* who = "normal section walks";
  validate_options(options, who);
  if (count < 0 || (count > 0 && !walks)) throw std::invalid_argument("normal section walks: missing walks");
  if (int64_t(walk.tris.size()) != mesh.num_triangles)
    throw std::invalid_argument("normal section walks: the walk mesh was built for another mesh");
  std::vector<SectionWalkRequest> in(walks, walks + count);
  for (int64_t i = 0; i < count; ++i) {
    SectionWalkRequest& w = in[size_t(i)];
    w.start = checked_surface_point(w.start, mesh.num_triangles, who, "walk", i);
    const V3 d = w.direction;
    if (!std::isfinite(d.x) || !std::isfinite(d.y) || !std::isfinite(d.z) || dot(d, d) == 0)
      throw std::invalid_argument("normal section walks: direction of walk " + std::to_string(i) + " is NaN or zero");
    if (!std::isfinite(w.length) || w.length <= 0) {
      std::ostringstream msg;
      msg << who << ": length of walk " << i << " is " << w.length << " (must be finite and > 0)";
      throw std::invalid_argument(msg.str());
    }
  }
  throw_if_cancelled(cancel);
  std::vector<SectionWalkResult> out(static_cast<size_t>(count));
  parallel_items(count, cancel, [&](int64_t i) {
    const SectionWalkRequest& w = in[size_t(i)];
    out[size_t(i)] = walk_normal_section(walk, mesh, w.start, w.direction, w.length, options);
  });
  return out;
}

std::vector<PseudoGeodesic> pseudo_geodesic_distances(const WalkMesh& walk, const TriangleMeshInput& mesh,
                                                      const SurfacePoint* p1, const SurfacePoint* p2, int64_t count,
                                                      const SectionWalkOptions& options,
                                                      const std::atomic<bool>* cancel) {
  const char* who = "pseudo-geodesic distances";
  validate_options(options, who);
  if (count < 0 || (count > 0 && (!p1 || !p2))) throw std::invalid_argument("pseudo-geodesic distances: missing points");
  if (int64_t(walk.tris.size()) != mesh.num_triangles)
    throw std::invalid_argument("pseudo-geodesic distances: the walk mesh was built for another mesh");
  std::vector<SurfacePoint> a(static_cast<size_t>(count)), b(static_cast<size_t>(count));
  for (int64_t i = 0; i < count; ++i) {
    a[size_t(i)] = checked_surface_point(p1[i], mesh.num_triangles, who, "first point", i);
    b[size_t(i)] = checked_surface_point(p2[i], mesh.num_triangles, who, "second point", i);
  }
  throw_if_cancelled(cancel);
  std::vector<PseudoGeodesic> out(static_cast<size_t>(count));
  parallel_items(count, cancel, [&](int64_t i) {
    out[size_t(i)] = pseudo_geodesic_distance(walk, mesh, a[size_t(i)], b[size_t(i)], options);
  });
  return out;
}

SurfaceWalkMesh build_surface_walk_mesh(const TriangleMeshInput& m, const std::atomic<bool>* cancel) {
  if (m.num_vertices < 0 || m.num_triangles < 0) throw std::invalid_argument("surface walk mesh: negative vertex or triangle count");
  if (m.num_triangles > (std::numeric_limits<int32_t>::max() >> 2))
    throw std::invalid_argument("surface walk mesh: too many triangles (" + std::to_string(m.num_triangles) + ")");
  if ((m.num_vertices > 0 && !m.positions) || (m.num_triangles > 0 && !m.triangles))
    throw std::invalid_argument("surface walk mesh: missing positions or triangles");
  if (m.num_triangles == 0) throw std::invalid_argument("surface walk mesh: the mesh has no triangles");
  for (int64_t i = 0; i < int64_t(m.num_vertices) * 3; ++i)
    if (!std::isfinite(m.positions[i]))
      throw std::invalid_argument("surface walk mesh: position of vertex " + std::to_string(i / 3) +
                                  " is NaN or infinite");
  for (int64_t i = 0; i < int64_t(m.num_triangles) * 3; ++i)
    if (m.triangles[i] < 0 || m.triangles[i] >= m.num_vertices)
      throw std::invalid_argument("surface walk mesh: triangle " + std::to_string(i / 3) + " references vertex " +
                                  std::to_string(m.triangles[i]) + " (mesh has " + std::to_string(m.num_vertices) +
                                  " vertices)");
  SurfaceWalkMesh s;
  s.positions.assign(m.positions, m.positions + 3 * size_t(m.num_vertices));
  s.triangles.assign(m.triangles, m.triangles + 3 * size_t(m.num_triangles));
  s.walk = build_walk_mesh(s.input(), cancel);
  return s;
}

}  // namespace texsynth
