// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/patches/grid_patch.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <limits>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

#include "texsynth/common/errors.hpp"
#include "texsynth/mesh/vertex_fill.hpp"

namespace texsynth {
namespace {

constexpr double kMaxMidpointGap = 1.0;     // two traces of one point further apart (in steps): invalid
constexpr double kMinCellArea = 0.1, kMaxCellArea = 4.0;  // in local h²
constexpr double kBarycentricTolerance = 1e-4;

bool set_vector(const float* d) {
  return std::isfinite(d[0]) && std::isfinite(d[1]) && std::isfinite(d[2]) && (d[0] != 0.f || d[1] != 0.f || d[2] != 0.f);
}

void validate(const PatchFieldInput& in, const PatchFieldParams& p) {
  const TriangleMeshInput& m = in.mesh;
  if (m.num_vertices < 0 || m.num_triangles < 0) throw std::invalid_argument("patch field: negative vertex or triangle count");
  if (m.num_triangles > (std::numeric_limits<int32_t>::max() >> 2))
    throw std::invalid_argument("patch field: too many triangles (" + std::to_string(m.num_triangles) + ")");
  if ((m.num_vertices > 0 && (!m.positions || !in.directions)) || (m.num_triangles > 0 && !m.triangles))
    throw std::invalid_argument("patch field: missing positions, triangles or directions");
  if (m.num_triangles == 0) throw std::invalid_argument("patch field: the mesh has no triangles");
  if (!std::isfinite(p.spacing) || p.spacing <= 0) throw std::invalid_argument("patch field: spacing must be finite and > 0");
  if (p.max_crossings < 1) throw std::invalid_argument("patch field: max_crossings must be >= 1");
  if (!(p.substep >= 0.05 && p.substep <= 1)) throw std::invalid_argument("patch field: substep must be in [0.05, 1]");
  if (!std::isfinite(p.singular_threshold) || p.singular_threshold < 0 || p.singular_threshold >= 1)
    throw std::invalid_argument("patch field: singular_threshold must be in [0, 1)");
  for (int64_t i = 0; i < int64_t(m.num_vertices) * 3; ++i)
    if (!std::isfinite(m.positions[i]))
      throw std::invalid_argument("patch field: position of vertex " + std::to_string(i / 3) + " is NaN or infinite");
  for (int64_t i = 0; i < int64_t(m.num_triangles) * 3; ++i)
    if (m.triangles[i] < 0 || m.triangles[i] >= m.num_vertices)
      throw std::invalid_argument("patch field: triangle " + std::to_string(i / 3) + " references vertex " +
                                  std::to_string(m.triangles[i]) + " (mesh has " + std::to_string(m.num_vertices) +
                                  " vertices)");
  if (in.density)
    for (int32_t v = 0; v < m.num_vertices; ++v)
      if (!std::isfinite(in.density[v]) || in.density[v] <= 0.f)
        throw std::invalid_argument("patch field: density of vertex " + std::to_string(v) + " must be finite and > 0");
}

// Unset vectors take the nearest set vertex's along triangle edges: breadth first from every set
// vertex in index order, so the result is deterministic.
std::vector<float> fill_unset(const TriangleMeshInput& m, const float* dirs, int64_t* unset) {
  const int32_t nv = m.num_vertices;
  std::vector<int32_t> start(size_t(nv) + 1, 0), adj;
  for (int64_t c = 0; c < int64_t(m.num_triangles) * 3; ++c) start[size_t(m.triangles[c]) + 1] += 2;
  for (int32_t v = 0; v < nv; ++v) start[v + 1] += start[v];
  adj.resize(size_t(start[nv]));
  std::vector<int32_t> fill(start.begin(), start.end() - 1);
  for (int32_t t = 0; t < m.num_triangles; ++t)
    for (int k = 0; k < 3; ++k) {
      const int32_t v = m.triangles[3 * size_t(t) + k];
      adj[size_t(fill[v]++)] = m.triangles[3 * size_t(t) + (k + 1) % 3];
      adj[size_t(fill[v]++)] = m.triangles[3 * size_t(t) + (k + 2) % 3];
    }
  std::vector<float> out(3 * size_t(nv), 0.f);
  std::vector<uint8_t> known(size_t(nv), 0);
  int64_t set = 0;
  for (int32_t v = 0; v < nv; ++v)
    if (set_vector(dirs + 3 * size_t(v))) {
      std::copy_n(dirs + 3 * size_t(v), 3, &out[3 * size_t(v)]);
      known[v] = 1;
      ++set;
    }
  if (set == 0) throw std::invalid_argument("patch field: no vertex has a direction (all zero or NaN)");
  *unset = nv - set;
  fill_from_known_vertices(start.data(), adj.data(), nv, known, out.data());
  return out;
}

// The tracing state: a triangle and the barycentrics of its three corners.
struct Walker {
  int32_t t;
  double beta[3];
};

class Tracer {
 public:
  explicit Tracer(const PatchField& f) : f_(f), m_(f.mesh()) {}

  V3 position(const Walker& w) const {
    const int32_t* c = m_.triangles + 3 * size_t(w.t);
    return mesh_position(m_, c[0]) * w.beta[0] + mesh_position(m_, c[1]) * w.beta[1] +
           mesh_position(m_, c[2]) * w.beta[2];
  }
  double scale(const Walker& w) const {
    const int32_t* c = m_.triangles + 3 * size_t(w.t);
    return f_.scale[c[0]] * w.beta[0] + f_.scale[c[1]] * w.beta[1] + f_.scale[c[2]] * w.beta[2];
  }
  V3 normal(int32_t t) const { return f_.walk.tris[t].normal; }
  double spacing() const { return f_.spacing; }

  // Unit direction of grid axis `axis` (0: +x, 1: -x, 2: +y, 3: -y) at (t, beta); false at a singularity.
  bool direction(int32_t t, const double beta[3], int axis, V3& out) const {
    const V3* cf = &f_.corner_field[3 * size_t(t)];
    const V3 up = cf[0] * beta[0] + cf[1] * beta[1] + cf[2] * beta[2];
    const double len = norm(up);
    if (!(len > f_.singular_threshold) || !std::isfinite(len)) return false;
    const V3 u = up * (1.0 / len);
    const V3 d = axis < 2 ? cross(u, f_.walk.tris[t].normal) : u;
    out = (axis & 1) ? d * -1.0 : d;
    return true;
  }

  // One grid step along `axis`: ∫ ds / h = 1. False when the trace stops (w is then unspecified).
  bool step(Walker& w, int axis) const {
    double remaining = 1.0;
    int32_t crossings = 0;
    int entered = -1;  // barycentric coordinate that is 0 on the edge we came in through
    const double h0 = f_.spacing;
    // Each pass either consumes a sub-step or crosses an edge; this also bounds passes that do neither.
    for (int guard = 0; guard < 64 + 4 * f_.max_crossings && remaining > 1e-12; ++guard) {
      const WalkTriangle& wt = f_.walk.tris[w.t];
      V3 d0;
      if (!direction(w.t, w.beta, axis, d0)) return false;
      const double h_here = h0 * scale(w);
      const double ds = std::min(remaining, f_.substep) * h_here;
      // Midpoint rule inside the face (the field is smooth there); at the face's edge keep d0.
      double r0[3] = {0, dot(wt.grad1, d0), dot(wt.grad2, d0)};
      r0[0] = -(r0[1] + r0[2]);
      Walker mid = w;
      bool inside = true;
      for (int k = 0; k < 3; ++k) {
        mid.beta[k] += 0.5 * ds * r0[k];
        inside = inside && mid.beta[k] >= 0;
      }
      V3 d = d0;
      double h_mid = h_here;
      if (inside) {
        V3 dm;
        if (!direction(w.t, mid.beta, axis, dm)) return false;
        d = dm;
        h_mid = h0 * scale(mid);
      }
      double r[3] = {0, dot(wt.grad1, d), dot(wt.grad2, d)};
      r[0] = -(r[1] + r[2]);
      if (entered >= 0 && r[entered] < 0) {
        // The field turns back across the edge just crossed: follow the edge instead.
        const int j = (entered + 1) % 3, k = (entered + 2) % 3;
        const int32_t* c = m_.triangles + 3 * size_t(w.t);
        const V3 edge = normalized_or(mesh_position(m_, c[k]) - mesh_position(m_, c[j]), V3{});
        d = edge * dot(d, edge);
        if (norm(d) < 1e-6) return false;  // head-on: a sink on the edge
        r[1] = dot(wt.grad1, d), r[2] = dot(wt.grad2, d), r[0] = -(r[1] + r[2]);
        r[entered] = 0;
      }
      const double speed = norm(d);
      // The exit edge: the first coordinate to reach 0.
      int exit = -1;
      double s_exit = 0;
      for (int i = 0; i < 3; ++i)
        if (r[i] < 0) {
          const double s = std::max(w.beta[i], 0.0) / -r[i];
          if (exit < 0 || s < s_exit) exit = i, s_exit = s;
        }
      const double s_move = ds / speed;  // parameter along d for arc length ds
      if (exit < 0 || s_exit >= s_move) {
        for (int k = 0; k < 3; ++k) w.beta[k] += s_move * r[k];
        remaining -= ds / h_mid;
        entered = -1;
        continue;
      }
      for (int k = 0; k < 3; ++k) w.beta[k] += s_exit * r[k];
      remaining -= s_exit * speed / h_mid;
      // Across edge j (corners j -> k, opposite the exit coordinate).
      const int j = (exit + 1) % 3, k = (exit + 2) % 3;
      const int32_t across = wt.across[j];
      if (across < 0 || ++crossings > f_.max_crossings) return false;
      const int32_t nt = across >> 2, ne = across & 3;
      const double bk = std::clamp(w.beta[k], 0.0, 1.0);
      w.t = nt;
      w.beta[ne] = bk, w.beta[(ne + 1) % 3] = 1 - bk, w.beta[(ne + 2) % 3] = 0;
      entered = (ne + 2) % 3;
    }
    return remaining <= 1e-12;
  }

  // The point of face a or b nearest to q (q is the midpoint of two traces ending in those faces).
  Walker snap(V3 q, int32_t a, int32_t b) const {
    Walker best{-1, {0, 0, 0}};
    double best_d = std::numeric_limits<double>::infinity();
    for (int32_t t : {a, b}) {
      Walker w{t, {0, 0, 0}};
      closest_in_triangle(q, w);
      const double d = norm(position(w) - q);
      if (d < best_d) best_d = d, best = w;
    }
    return best;
  }

 private:
  // Barycentrics of the point of triangle w.t nearest to q.
  void closest_in_triangle(V3 q, Walker& w) const {
    const int32_t* c = m_.triangles + 3 * size_t(w.t);
    const V3 p[3] = {mesh_position(m_, c[0]), mesh_position(m_, c[1]), mesh_position(m_, c[2])};
    const WalkTriangle& wt = f_.walk.tris[w.t];
    const double b1 = dot(wt.grad1, q - p[0]), b2 = dot(wt.grad2, q - p[0]);
    if (b1 >= 0 && b2 >= 0 && b1 + b2 <= 1) {
      w.beta[0] = 1 - b1 - b2, w.beta[1] = b1, w.beta[2] = b2;
      return;
    }
    // Outside: the nearest point of the three edges.
    double best = std::numeric_limits<double>::infinity();
    for (int e = 0; e < 3; ++e) {
      const V3 a = p[e], ab = p[(e + 1) % 3] - a;
      const double len2 = dot(ab, ab);
      const double s = len2 > 0 ? std::clamp(dot(q - a, ab) / len2, 0.0, 1.0) : 0.0;
      const V3 x = a + ab * s;
      const double d = dot(x - q, x - q);
      if (d < best) {
        best = d;
        w.beta[e] = 1 - s, w.beta[(e + 1) % 3] = s, w.beta[(e + 2) % 3] = 0;
      }
    }
  }

  const PatchField& f_;
  const TriangleMeshInput m_;
};

FacePoint face_point(const Walker& w) { return {w.t, float(w.beta[1]), float(w.beta[2])}; }

// One patch into its slots of `out` (points, positions, cells).
// Thin parts (docs/algorithms/vector_field_patches.md, "Thin parts"): a patch wider than the part it lies
// on (a leg, a branch, a thin cylinder) wraps round it and meets itself, pasting two patch regions onto one
// spot. On a sub-grid of every kThinStride-th point, two points far apart in the grid (> 2 strides) but
// within kThinDistance steps in 3D (the sub-grid of a sheet lying on itself is never farther apart than 2√2
// steps) mean the patch has come round: every point at or beyond that ring (Chebyshev distance from the
// centre), less a stride of slack, is made invalid. The samples there are covered by other patches, an
// extra round or continued.
constexpr int kThinStride = 4;
constexpr double kThinDistance = 3.0;  // steps
void truncate_thin_part(std::vector<Walker>& grid, const std::vector<V3>& p, int32_t n, double h) {
  const int32_t c = n / 2;
  std::vector<int32_t> sub;
  for (int32_t j = c % kThinStride; j < n; j += kThinStride)
    for (int32_t i = c % kThinStride; i < n; i += kThinStride)
      if (grid[size_t(j) * n + i].t >= 0) sub.push_back(j * n + i);
  auto ring = [&](int32_t k) { return std::max(std::abs(k % n - c), std::abs(k / n - c)); };
  const double limit2 = (kThinDistance * h) * (kThinDistance * h);
  int32_t cut = n;  // the first ring that meets another part of the patch
  for (size_t a = 0; a < sub.size(); ++a)
    for (size_t b = a + 1; b < sub.size(); ++b) {
      const int32_t ka = sub[a], kb = sub[b];
      const int32_t grid_apart = std::max(std::abs(ka % n - kb % n), std::abs(ka / n - kb / n));
      if (grid_apart <= 2 * kThinStride) continue;
      const V3 d = p[size_t(ka)] - p[size_t(kb)];
      if (dot(d, d) < limit2) cut = std::min(cut, std::max(ring(ka), ring(kb)));
    }
  if (cut >= n) return;
  const int32_t keep = std::max(1, cut - kThinStride);  // rings < keep stay
  for (int32_t k = 0; k < n * n; ++k)
    if (ring(k) >= keep) grid[size_t(k)].t = -1;
}

void trace_patch(const Tracer& tr, const FacePoint& centre, int32_t n, FacePoint* pts, float* pos, uint8_t* cells,
                 int64_t& invalid_points, int64_t& invalid_cells) {
  std::vector<Walker> grid(size_t(n) * size_t(n), Walker{-1, {0, 0, 0}});
  const int32_t c = n / 2;
  auto at = [&](int32_t i, int32_t j) -> Walker& { return grid[size_t(j) * size_t(n) + size_t(i)]; };
  at(c, c) = {centre.triangle, {1.0 - double(centre.b1) - double(centre.b2), centre.b1, centre.b2}};
  auto advance = [&](const Walker& from, int axis) {
    Walker w = from;
    if (w.t < 0 || !tr.step(w, axis)) w.t = -1;
    return w;
  };
  // Centre row and column, outwards.
  for (int32_t i = c + 1; i < n; ++i) at(i, c) = advance(at(i - 1, c), 0);
  for (int32_t i = c - 1; i >= 0; --i) at(i, c) = advance(at(i + 1, c), 1);
  for (int32_t j = c + 1; j < n; ++j) at(c, j) = advance(at(c, j - 1), 2);
  for (int32_t j = c - 1; j >= 0; --j) at(c, j) = advance(at(c, j + 1), 3);
  // Each quadrant row by row away from the centre: both parents are done before their child.
  for (int sj : {1, -1})
    for (int si : {1, -1})
      for (int32_t j = c + sj; j >= 0 && j < n; j += sj)
        for (int32_t i = c + si; i >= 0 && i < n; i += si) {
          const Walker a = advance(at(i - si, j), si > 0 ? 0 : 1);
          const Walker b = advance(at(i, j - sj), sj > 0 ? 2 : 3);
          Walker& out = at(i, j);
          if (a.t < 0 || b.t < 0) {
            out = a.t >= 0 ? a : b;
            continue;
          }
          const V3 pa = tr.position(a), pb = tr.position(b);
          const double h = 0.5 * (tr.scale(a) + tr.scale(b));
          if (norm(pa - pb) > kMaxMidpointGap * h * tr.spacing()) {
            out.t = -1;
            continue;
          }
          out = tr.snap((pa + pb) * 0.5, a.t, b.t);
        }
  std::vector<V3> p(grid.size());
  for (size_t k = 0; k < grid.size(); ++k) p[k] = grid[k].t >= 0 ? tr.position(grid[k]) : V3{};
  truncate_thin_part(grid, p, n, tr.spacing() * tr.scale(at(c, c)));
  for (size_t k = 0; k < grid.size(); ++k) {
    pts[k] = grid[k].t >= 0 ? face_point(grid[k]) : FacePoint{};
    if (grid[k].t < 0) p[k] = V3{};
    store(pos + 3 * k, p[k]);
    invalid_points += grid[k].t < 0;
  }
  // Cells: four valid corners, a plausible area, facing the same way as the surface.
  for (int32_t j = 0; j + 1 < n; ++j)
    for (int32_t i = 0; i + 1 < n; ++i) {
      const size_t k00 = size_t(j) * n + i, k10 = k00 + 1, k01 = k00 + n, k11 = k01 + 1;
      uint8_t ok = grid[k00].t >= 0 && grid[k10].t >= 0 && grid[k01].t >= 0 && grid[k11].t >= 0;
      if (ok) {
        const V3 area2 = cross(p[k11] - p[k00], p[k01] - p[k10]);  // 2 × area × normal (x then y: right-handed)
        double h = 0;
        V3 n_sum;
        for (size_t k : {k00, k10, k01, k11}) h += tr.scale(grid[k]) * 0.25, n_sum = n_sum + tr.normal(grid[k].t);
        h *= tr.spacing();
        const double area = 0.5 * norm(area2);
        ok = area >= kMinCellArea * h * h && area <= kMaxCellArea * h * h && dot(area2, n_sum) > 0;
      }
      cells[size_t(j) * (n - 1) + i] = ok;
      invalid_cells += !ok;
    }
}

}  // namespace

PatchField build_patch_field(const PatchFieldInput& in, const PatchFieldParams& p) {
  validate(in, p);
  throw_if_cancelled(p.cancel);
  const TriangleMeshInput& m = in.mesh;
  PatchField f;
  f.positions.assign(m.positions, m.positions + 3 * size_t(m.num_vertices));
  f.triangles.assign(m.triangles, m.triangles + 3 * size_t(m.num_triangles));
  f.spacing = p.spacing;
  f.max_crossings = p.max_crossings;
  f.singular_threshold = p.singular_threshold;
  f.substep = p.substep;
  const PatchField* base = p.reuse_mesh;
  if (base && base->positions == f.positions && base->triangles == f.triangles) {
    f.walk = base->walk;
    f.reused_mesh = true;
  } else {
    f.walk = build_walk_mesh(f.mesh(), p.cancel);
  }
  const std::vector<float> dirs = fill_unset(m, in.directions, &f.unset_vertices);
  throw_if_cancelled(p.cancel);

  // Scale: g = 1 / density, times |v| / median |v| when the magnitude drives it.
  const int32_t nv = m.num_vertices;
  f.scale.assign(size_t(nv), 1.f);
  double median = 1;
  if (in.magnitude_scale) {
    std::vector<double> len(static_cast<size_t>(nv));
    for (int32_t v = 0; v < nv; ++v) len[v] = norm(v3(&dirs[3 * size_t(v)]));
    std::vector<double> sorted = len;
    std::nth_element(sorted.begin(), sorted.begin() + nv / 2, sorted.end());
    median = sorted[size_t(nv / 2)];
    for (int32_t v = 0; v < nv; ++v) f.scale[v] = float(len[v] / median);
  }
  for (int32_t v = 0; v < nv; ++v) {
    double g = f.scale[v];
    if (in.density) g /= in.density[v];
    f.scale[v] = float(std::clamp(g, kMinGridScale, kMaxGridScale));
  }

  f.corner_field.assign(3 * size_t(m.num_triangles), V3{});
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, m.num_triangles, 4096), [&](const tbb::blocked_range<int32_t>& r) {
    throw_if_cancelled(p.cancel);
    for (int32_t t = r.begin(); t < r.end(); ++t) {
      const WalkTriangle& wt = f.walk.tris[t];
      if (wt.degenerate) continue;
      for (int k = 0; k < 3; ++k) {
        const V3 d = v3(&dirs[3 * size_t(m.triangles[3 * size_t(t) + k])]);
        f.corner_field[3 * size_t(t) + k] = normalized_or(project_to_plane(normalized_or(d, V3{}), wt.normal), V3{});
      }
    }
  });
  return f;
}

GridPatches trace_grid_patches(const PatchField& field, const FacePoint* centres, int32_t count, int32_t size,
                               const std::atomic<bool>* cancel) {
  if (size < 2 || size > kMaxGridPatchSize)
    throw std::invalid_argument("grid patches: size must be 2.." + std::to_string(kMaxGridPatchSize) + ", got " +
                                std::to_string(size));
  if (count < 0 || (count > 0 && !centres)) throw std::invalid_argument("grid patches: missing centres");
  const int32_t nt = int32_t(field.triangles.size() / 3);
  for (int32_t i = 0; i < count; ++i) {
    const FacePoint& c = centres[i];
    if (c.triangle < 0 || c.triangle >= nt)
      throw std::invalid_argument("grid patches: centre " + std::to_string(i) + " is in triangle " +
                                  std::to_string(c.triangle) + " (mesh has " + std::to_string(nt) + " triangles)");
    if (!std::isfinite(c.b1) || !std::isfinite(c.b2) || c.b1 < -kBarycentricTolerance ||
        c.b2 < -kBarycentricTolerance || c.b1 + c.b2 > 1 + kBarycentricTolerance) {
      std::ostringstream msg;
      msg << "grid patches: barycentrics of centre " << i << " (" << c.b1 << ", " << c.b2
          << ") are not inside the triangle";
      throw std::invalid_argument(msg.str());
    }
  }
  GridPatches out;
  out.size = size;
  out.count = count;
  const size_t per = size_t(size) * size_t(size), cells = size_t(size - 1) * size_t(size - 1);
  out.points.resize(per * size_t(count));
  out.positions.resize(3 * per * size_t(count));
  out.cell_valid.resize(cells * size_t(count));
  std::atomic<int64_t> invalid_points{0}, invalid_cells{0};
  const Tracer tracer(field);
  // Every patch into its own slots: the same bytes for any thread count.
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, count, 4), [&](const tbb::blocked_range<int32_t>& r) {
    int64_t ip = 0, ic = 0;
    for (int32_t i = r.begin(); i < r.end(); ++i) {
      throw_if_cancelled(cancel);
      FacePoint c = centres[i];
      c.b1 = std::max(c.b1, 0.f), c.b2 = std::max(c.b2, 0.f);
      if (c.b1 + c.b2 > 1.f) {
        const float s = c.b1 + c.b2;
        c.b1 /= s, c.b2 /= s;
      }
      trace_patch(tracer, c, size, &out.points[per * i], &out.positions[3 * per * i], &out.cell_valid[cells * i], ip,
                  ic);
    }
    invalid_points += ip, invalid_cells += ic;
  });
  out.invalid_points = invalid_points.load();
  out.invalid_cells = invalid_cells.load();
  return out;
}

CellCoordinates cell_coordinates(V3 p00, V3 p10, V3 p11, V3 p01, V3 point) {
  CellCoordinates out;
  // The cell's mean plane: normal from the diagonals, origin at the corners' centroid.
  const V3 normal = normalized_or(cross(p11 - p00, p01 - p10), V3{});
  if (norm(normal) == 0) return out;
  const V3 centroid = (p00 + p10 + p11 + p01) * 0.25;
  const V3 ex = normalized_or(project_to_plane(p10 - p00 + (p11 - p01), normal), V3{});
  if (norm(ex) == 0) return out;
  const V3 ey = cross(normal, ex);
  auto flat = [&](V3 q) {
    const V3 d = q - centroid;
    return std::array<double, 2>{dot(d, ex), dot(d, ey)};
  };
  const auto a = flat(p00), b = flat(p10), c = flat(p11), d = flat(p01), q = flat(point);
  out.distance = std::fabs(dot(point - centroid, normal));
  // q = a + s·e + t·f + s·t·g.
  const double e[2] = {b[0] - a[0], b[1] - a[1]}, f[2] = {d[0] - a[0], d[1] - a[1]};
  const double g[2] = {a[0] - b[0] + c[0] - d[0], a[1] - b[1] + c[1] - d[1]};
  const double h[2] = {q[0] - a[0], q[1] - a[1]};
  auto cross2 = [](const double* u, const double* v) { return u[0] * v[1] - u[1] * v[0]; };
  // Eliminating s gives k2·t² + k1·t + k0 = 0.
  const double k2 = cross2(g, f), k1 = cross2(e, f) + cross2(h, g), k0 = cross2(h, e);
  const double scale = std::max({std::fabs(cross2(e, f)), 1e-300});
  double roots[2];
  int count = 0;
  if (std::fabs(k2) <= 1e-12 * scale) {
    if (std::fabs(k1) > 0) roots[count++] = -k0 / k1;
  } else {
    const double disc = k1 * k1 - 4 * k0 * k2;
    if (disc >= 0) {
      // Numerically stable pair.
      const double qq = -0.5 * (k1 + std::copysign(std::sqrt(disc), k1));
      roots[count++] = qq / k2;
      if (qq != 0) roots[count++] = k0 / qq;
    }
  }
  double best = std::numeric_limits<double>::infinity();
  for (int i = 0; i < count; ++i) {
    const double t = roots[i];
    const double den0 = e[0] + g[0] * t, den1 = e[1] + g[1] * t;
    if (std::fabs(den0) < 1e-300 && std::fabs(den1) < 1e-300) continue;
    const double s = std::fabs(den0) >= std::fabs(den1) ? (h[0] - f[0] * t) / den0 : (h[1] - f[1] * t) / den1;
    // Prefer the root inside the cell (the other lies beyond the bilinear surface's fold).
    const double outside = std::max({0.0, -s, s - 1}) + std::max({0.0, -t, t - 1});
    if (outside < best) best = outside, out.s = s, out.t = t, out.ok = std::isfinite(s) && std::isfinite(t);
  }
  return out;
}

void append_grid_patches(GridPatches& into, const GridPatches& more) {
  if (into.size != more.size) throw std::invalid_argument("append grid patches: different patch sizes");
  into.count += more.count;
  into.points.insert(into.points.end(), more.points.begin(), more.points.end());
  into.positions.insert(into.positions.end(), more.positions.begin(), more.positions.end());
  into.cell_valid.insert(into.cell_valid.end(), more.cell_valid.begin(), more.cell_valid.end());
  into.invalid_points += more.invalid_points;
  into.invalid_cells += more.invalid_cells;
}

}  // namespace texsynth
