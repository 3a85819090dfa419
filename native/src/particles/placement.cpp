// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/particles/placement.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>

#include "texsynth/common/errors.hpp"
#include "texsynth/common/hash.hpp"
#include "texsynth/common/rng.hpp"
#include "texsynth/mesh/spatial_cells.hpp"

namespace texsynth {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kBarycentricTolerance = 1e-4;
constexpr uint64_t kClassStreamSalt = 0x70a1c3e5u;
constexpr int kCancelEvery = 256;  // accept-loop iterations between cancel checks

double fold_half_turn(double a) {
  a = std::remainder(a, kPi);  // [-pi/2, pi/2]
  return a <= -kPi / 2 ? a + kPi : a;
}

[[noreturn]] void refuse(const std::string& what) { throw std::invalid_argument("particle placement: " + what); }

// What the surface says at a point: frame, pixel size and the overrides of its triangle.
struct Local {
  V3 position, normal, right, up;
  double pixel = 0;    // world units per sample pixel (scale field only)
  double density = 1;  // clamped; 0 = no particle here
  double probability = 1;
  double size = 1;  // face size override, clamped; 0 = no particle here
  bool empty() const { return density == 0 || size == 0; }
};

struct Placed {
  SurfacePoint at;
  Local l;
  V3 axis;                        // box x axis, world unit vector in the tangent plane
  double theta = 0;               // box angle in the local frame, folded
  double half_x = 0, half_y = 0;  // world half extents
  double reach = 1;               // 1 / sqrt(density): conflicts use the box scaled like the offsets
  double ex_x = 0, ex_y = 0;      // exclusion half extents: (box + half the class's least gap) x reach
  double bound = 0;               // half diagonal of the exclusion box
  double bound_all = 0;           // half diagonal of the box grown by the largest margin of any class pair
  double unit = 0;                // world units per box pixel: pixel x size factor
  int32_t sprite = -1, parent = -1, cls = -1;
  uint8_t origin = 0;
  bool visible = true;
  double radius() const { return bound; }
};

// 2D box: centre, unit x axis, half extents.
struct Box2 {
  double cx, cy, ux, uy, hx, hy;
};

// True when an axis of a or b separates them (then they do not intersect).
bool boxes_apart(const Box2& a, const Box2& b) {
  const double dx = b.cx - a.cx, dy = b.cy - a.cy;
  const double axes[4][2] = {{a.ux, a.uy}, {-a.uy, a.ux}, {b.ux, b.uy}, {-b.uy, b.ux}};
  for (int k = 0; k < 4; ++k) {
    const double x = axes[k][0], y = axes[k][1];
    const double ra = a.hx * std::abs(a.ux * x + a.uy * y) + a.hy * std::abs(-a.uy * x + a.ux * y);
    const double rb = b.hx * std::abs(b.ux * x + b.uy * y) + b.hy * std::abs(-b.uy * x + b.ux * y);
    if (std::abs(dx * x + dy * y) >= ra + rb) return true;
  }
  return false;
}

// Area of a ∩ b: a's corners clipped by b's four half-planes (at most 8 corners, no allocation).
double box_overlap_area(const Box2& a, const Box2& b) {
  double px[8], py[8], qx[8], qy[8];
  int n = 4;
  const double su[4] = {-1, 1, 1, -1}, sv[4] = {-1, -1, 1, 1};
  for (int i = 0; i < 4; ++i) {
    const double u = su[i] * a.hx, v = sv[i] * a.hy;
    px[i] = a.cx + u * a.ux - v * a.uy, py[i] = a.cy + u * a.uy + v * a.ux;
  }
  const double axes[2][2] = {{b.ux, b.uy}, {-b.uy, b.ux}}, half[2] = {b.hx, b.hy};
  for (int k = 0; k < 4 && n > 0; ++k) {
    const double s = k & 1 ? -1.0 : 1.0, ax = s * axes[k / 2][0], ay = s * axes[k / 2][1], h = half[k / 2];
    auto side = [&](double x, double y) { return (x - b.cx) * ax + (y - b.cy) * ay - h; };  // <= 0 inside
    int m = 0;
    for (int i = 0; i < n; ++i) {
      const int j = (i + 1) % n;
      const double si = side(px[i], py[i]), sj = side(px[j], py[j]);
      if (si <= 0) qx[m] = px[i], qy[m] = py[i], ++m;
      if ((si <= 0) != (sj <= 0) && m < 8) {
        const double t = si / (si - sj);
        qx[m] = px[i] + t * (px[j] - px[i]), qy[m] = py[i] + t * (py[j] - py[i]), ++m;
      }
    }
    n = m;
    std::copy(qx, qx + n, px), std::copy(qy, qy + n, py);
  }
  double area = 0;
  for (int i = 0; i < n; ++i) {
    const int j = (i + 1) % n;
    area += px[i] * py[j] - px[j] * py[i];
  }
  return std::abs(0.5 * area);
}

// Particles by 3D cell (centres relative to the mesh's lower corner): one grid per class (re-seeding and
// dart distances) and one of every class (conflicts). Queries wider than the particles it holds scan the
// list instead.
struct ClassGrid {
  double cell = 1;
  V3 origin;
  std::unordered_map<uint64_t, std::vector<int32_t>> cells;
  std::vector<int32_t> members;
  double max_radius = 0;

  bool key_of(V3 p, int64_t c[3]) const { return spatial_cell(p - origin, cell, c, 2); }
  void insert(int32_t index, V3 p, double radius) {
    members.push_back(index);
    max_radius = std::max(max_radius, radius);
    int64_t c[3];
    if (key_of(p, c)) cells[spatial_cell_key(c[0], c[1], c[2])].push_back(index);
  }
  // f(index) for candidates within `radius` of p (a superset): the cells the ball touches, or the whole
  // list when that is shorter; stops when f returns true.
  template <class F>
  void near(V3 p, double radius, F&& f) const {
    int64_t lo[3], hi[3];
    const double span = std::ceil(2 * radius / cell) + 1;
    if (!(span < 128) || span * span * span > double(members.size()) || !key_of(p - V3{radius, radius, radius}, lo) ||
        !key_of(p + V3{radius, radius, radius}, hi)) {
      for (int32_t i : members)
        if (f(i)) return;
      return;
    }
    for (int64_t x = lo[0]; x <= hi[0]; ++x)
      for (int64_t y = lo[1]; y <= hi[1]; ++y)
        for (int64_t z = lo[2]; z <= hi[2]; ++z) {
          const auto it = cells.find(spatial_cell_key(x, y, z));
          if (it == cells.end()) continue;
          for (int32_t i : it->second)
            if (f(i)) return;
        }
  }
};

struct ClassPlan {
  int32_t id = 0;
  std::vector<int32_t> complete;  // sprites
  std::vector<int32_t> lists;     // complete particles with a non-empty list
  bool random = false;
  double tolerance = 0.1;
  double spacing_px = 0;     // mean centre distance to measured neighbours
  double mean_box_px = 0;    // mean box area
  double max_radius_px = 0;  // largest half diagonal
  double margin_px = 0;      // half the low percentile of nearest box gaps (>= 0), from the analysis
  double density_px = 0, min_distance_px = 0;
};

struct Child {
  int32_t parent = -1, sprite = -1, entry = -1;
  double jitter = 1;
  SurfacePoint at;
  Local l;
  bool reached = false;
  bool refused = false;  // conflicts with a particle of an earlier generation
};

class Placer {
 public:
  Placer(const ParticleAnalysis& a, const SurfaceWalkMesh& m, const PlacementParams& p)
      : a_(a), m_(m), p_(p), in_(m.input()) {}

  PlacedParticles run();

 private:
  const ParticleAnalysis& a_;
  const SurfaceWalkMesh& m_;
  const PlacementParams& p_;
  TriangleMeshInput in_;

  std::vector<double> area_;        // per triangle
  std::vector<int32_t> component_;  // per triangle, -1 = degenerate
  std::vector<std::vector<int32_t>> comp_tris_;
  std::vector<std::vector<double>> comp_cdf_;
  std::vector<std::vector<SurfacePoint>> comp_seeds_;
  V3 lower_, upper_;
  double min_scale_ = 1, median_scale_ = 1;

  std::vector<Placed> placed_;
  PlacementStats stats_;
  bool global_capped_ = false;
  double margin_px_ = 0;     // the running class's
  double max_margin_px_ = 0; // the largest margin of any pair of the placed classes
  double surface_px_ = 0;    // the surface in sample pixels^2 under the local pixel size and density
  std::vector<int32_t> dart_tris_;  // triangles where particles may stand..
  std::vector<double> dart_cdf_;    // ..and their cumulative area x density / pixel^2
  std::vector<double> tri_px_;      // per triangle: area x density / pixel^2 (0 where none may stand)
  std::vector<V3> tri_centre_, tri_normal_;
  ClassGrid all_;            // every placed particle (conflicts)
  std::vector<uint8_t> output_;  // per class: rows output

  void validate() const;
  void prepare_mesh();
  std::vector<int32_t> class_order() const;
  ClassPlan plan_class(int32_t k) const;
  int64_t class_cap(const ClassPlan& cp) const;

  Local local(const SurfacePoint& sp, V3 fallback_up) const;
  SurfacePoint random_point(const std::vector<int32_t>& tris, const std::vector<double>& cdf, Rng& rng) const;
  bool conflicts(const Placed& c, const ClassPlan& cp, int32_t from = 0) const;
  bool any_within(const ClassGrid& g, V3 p, V3 n, double radius) const;
  Placed make(const SurfacePoint& at, const Local& l, int32_t sprite, double theta, double jitter, double margin) const;
  Placed child_particle(const Child& ch) const {
    Placed c = make(ch.at, ch.l, ch.sprite, placed_[size_t(ch.parent)].theta + a_.cooc[size_t(ch.entry)].angle,
                    ch.jitter, margin_px_);
    c.cls = a_.particles[size_t(ch.sprite)].class_id;
    c.parent = ch.parent;
    c.origin = uint8_t(PlacementOrigin::propagated);
    return c;
  }

  struct ClassRun {
    const ClassPlan& cp;
    ClassPlacementStats& st;
    Rng rng;
    ClassGrid grid;
    ClassGrid triangles;  // triangle centroids, for the local count control's expected count
    double crowd_radius_px = 0;
    int64_t count = 0;
    bool stop = false;
  };
  bool accept(ClassRun& run, Placed&& c);
  struct LocalCount {
    double weighted = 0;  // the class's particles round c, weighted (1 - d^2 / r^2)^2
    double expected = 0;  // the same weighted count the surface inside the disc expects
    double nominal = 0;   // what a disc wholly on the surface expects
    double nearest = std::numeric_limits<double>::infinity();  // distance to the nearest other particle in it
  };
  LocalCount local_count(const ClassRun& run, const Placed& c, double stop_factor) const;
  bool crowded(const ClassRun& run, const Placed& c) const;
  void thin(ClassRun& run, size_t first);
  bool try_seed(ClassRun& run, const SurfacePoint& at, PlacementOrigin origin);
  void propagate(ClassRun& run, std::vector<int32_t> frontier, int32_t class_index, int32_t num_classes);
  void run_random(ClassRun& run);
  void prepare_darts();
  int64_t darts(ClassRun& run, int64_t target, PlacementOrigin origin);
  void report(int32_t class_index, int32_t num_classes, double within) const {
    if (p_.progress) p_.progress->store(float((class_index + std::clamp(within, 0.0, 0.99)) / num_classes));
  }
  PlacedParticles output() const;
  // body(t) for every triangle, in parallel; cancel checked per block.
  template <class Body>
  void parallel_triangles(Body&& body) const {
    tbb::parallel_for(tbb::blocked_range<int32_t>(0, in_.num_triangles, 2048),
                      [&](const tbb::blocked_range<int32_t>& r) {
                        throw_if_cancelled(p_.cancel);
                        for (int32_t t = r.begin(); t < r.end(); ++t) body(t);
                      });
  }
};

// ---------------------------------------------------------------------------------------------- input

void check_finite(const std::vector<float>& v, const char* name) {
  for (size_t i = 0; i < v.size(); ++i)
    if (!std::isfinite(v[i])) refuse(std::string(name) + "[" + std::to_string(i) + "] is NaN or infinite");
}

void Placer::validate() const {
  const ParticleAnalysis& a = a_;
  if (a.width <= 0 || a.height <= 0 || a.particles.empty() || a.classes.size() != size_t(a.num_classes) ||
      a.cooc_start.size() != a.particles.size() + 1)
    refuse("the analysis is empty or inconsistent");
  for (size_t i = 0; i < a.particles.size(); ++i) {
    const Particle& P = a.particles[i];
    if (P.class_id < 0 || P.class_id >= a.num_classes || !std::isfinite(P.box.half_x) || !std::isfinite(P.box.half_y) ||
        !std::isfinite(P.box.angle) || P.box.half_x < 0 || P.box.half_y < 0 || a.cooc_start[i] > a.cooc_start[i + 1])
      refuse("the analysis is inconsistent (particle " + std::to_string(i) + ")");
  }
  if (a.cooc_start.front() != 0 || size_t(a.cooc_start.back()) != a.cooc.size())
    refuse("the analysis is inconsistent (co-occurrence lists)");
  for (const ParticleClass& c : a.classes)
    if (!std::isfinite(c.density) || !std::isfinite(c.min_distance) || !std::isfinite(c.tolerance) || c.density < 0 ||
        c.min_distance < 0 || c.tolerance < 0)
      refuse("the analysis is inconsistent (a class table entry)");
  for (const CoOccurrence& e : a.cooc)
    if (e.quadrant < 0 || e.quadrant > 3 || !std::isfinite(e.dx) || !std::isfinite(e.dy) || !std::isfinite(e.angle))
      refuse("the analysis is inconsistent (a co-occurrence entry)");

  const int64_t V = in_.num_vertices, T = in_.num_triangles;
  if (int64_t(m_.walk.tris.size()) != T || int64_t(m_.walk.weld.size()) != V) refuse("the walk mesh is inconsistent");
  if (int64_t(p_.directions.size()) != 3 * V)
    refuse("directions has " + std::to_string(p_.directions.size()) + " values, expected 3 x " + std::to_string(V) +
           " vertices");
  check_finite(p_.directions, "directions");
  if (!std::isfinite(p_.sample_world_width) || p_.sample_world_width <= 0) {
    std::ostringstream s;
    s << "sample_world_width must be finite and > 0, got " << p_.sample_world_width;
    refuse(s.str());
  }
  auto per = [&](const std::vector<float>& v, int64_t n, const char* name, const char* what) {
    if (v.empty()) return;
    if (int64_t(v.size()) != n)
      refuse(std::string(name) + " has " + std::to_string(v.size()) + " values, expected " + std::to_string(n) + " (" +
             what + ")");
    check_finite(v, name);
  };
  per(p_.vertex_scale, V, "vertex_scale", "one per vertex");
  per(p_.face_density, T, "face_density", "one per triangle");
  per(p_.face_probability, T, "face_probability", "one per triangle");
  per(p_.face_size, T, "face_size", "one per triangle");
  for (size_t i = 0; i < p_.vertex_scale.size(); ++i)
    if (p_.vertex_scale[i] <= 0) refuse("vertex_scale[" + std::to_string(i) + "] must be > 0");
  for (size_t i = 0; i < p_.face_density.size(); ++i)
    if (p_.face_density[i] < 0) refuse("face_density[" + std::to_string(i) + "] must be >= 0");
  for (size_t i = 0; i < p_.face_size.size(); ++i)
    if (p_.face_size[i] < 0) refuse("face_size[" + std::to_string(i) + "] must be >= 0");
  for (size_t i = 0; i < p_.face_probability.size(); ++i)
    if (p_.face_probability[i] < 0 || p_.face_probability[i] > 1)
      refuse("face_probability[" + std::to_string(i) + "] must be in 0..1");
  if (!std::isfinite(p_.size_jitter) || p_.size_jitter < 0 || p_.size_jitter > kPlacementMaxJitter)
    refuse("size_jitter must be in 0..0.9, got " + std::to_string(p_.size_jitter));
  if (p_.max_particles < 1) refuse("max_particles must be >= 1, got " + std::to_string(p_.max_particles));
  for (size_t i = 0; i < p_.seeds.size(); ++i) {
    const SurfacePoint& s = p_.seeds[i];
    if (s.triangle < 0 || s.triangle >= T)
      refuse("seed " + std::to_string(i) + " is in triangle " + std::to_string(s.triangle) + " (mesh has " +
             std::to_string(T) + " triangles)");
    if (!std::isfinite(s.b1) || !std::isfinite(s.b2) || s.b1 < -kBarycentricTolerance ||
        s.b2 < -kBarycentricTolerance || s.b1 + s.b2 > 1 + kBarycentricTolerance)
      refuse("barycentrics of seed " + std::to_string(i) + " are NaN or not inside the triangle");
    if (m_.walk.tris[size_t(s.triangle)].degenerate)
      refuse("seed " + std::to_string(i) + " lies on a zero-area triangle");
  }
  std::vector<uint8_t> seen(size_t(a.num_classes), 0);
  for (int32_t k : p_.classes) {
    if (k < 0 || k >= a.num_classes)
      refuse("unknown class " + std::to_string(k) + " (classes 0.." + std::to_string(a.num_classes - 1) + ")");
    if (seen[size_t(k)]++) refuse("class " + std::to_string(k) + " is listed twice");
    if (k == a.background) refuse("class " + std::to_string(k) + " is the background class (it has no arrangement)");
    if (!a.classes[size_t(k)].has_complete)
      refuse("class " + std::to_string(k) + " has no complete particle (nothing to place)");
  }
}

void Placer::prepare_mesh() {
  const int32_t T = in_.num_triangles;
  area_.assign(size_t(T), 0);
  component_.assign(size_t(T), -1);
  double total = 0;
  lower_ = upper_ = mesh_position(in_, 0);
  for (int32_t v = 0; v < in_.num_vertices; ++v) {
    const V3 p = mesh_position(in_, v);
    lower_ = {std::min(lower_.x, p.x), std::min(lower_.y, p.y), std::min(lower_.z, p.z)};
    upper_ = {std::max(upper_.x, p.x), std::max(upper_.y, p.y), std::max(upper_.z, p.z)};
  }
  for (int32_t t = 0; t < T; ++t) {
    if (t % 4096 == 0) throw_if_cancelled(p_.cancel);
    if (m_.walk.tris[size_t(t)].degenerate) continue;
    const int32_t* c = in_.triangles + 3 * size_t(t);
    const V3 p0 = mesh_position(in_, c[0]);
    area_[size_t(t)] = 0.5 * norm(cross(mesh_position(in_, c[1]) - p0, mesh_position(in_, c[2]) - p0));
    total += area_[size_t(t)];
  }
  if (!(total > 0)) refuse("the mesh has no area");
  if (!std::isfinite(total) || !std::isfinite(norm(upper_ - lower_)))
    refuse("the mesh's area or extent overflows (coordinates too large)");
  // Components: faces joined across walkable edges, numbered by their lowest triangle.
  std::vector<int32_t> queue;
  for (int32_t t = 0; t < T; ++t) {
    if (component_[size_t(t)] >= 0 || m_.walk.tris[size_t(t)].degenerate) continue;
    if (t % 4096 == 0) throw_if_cancelled(p_.cancel);
    const int32_t id = int32_t(comp_tris_.size());
    comp_tris_.emplace_back();
    queue.assign(1, t);
    component_[size_t(t)] = id;
    for (size_t h = 0; h < queue.size(); ++h) {
      const int32_t u = queue[h];
      comp_tris_.back().push_back(u);
      for (int32_t across : m_.walk.tris[size_t(u)].across) {
        if (across < 0) continue;
        const int32_t w = across >> 2;
        if (component_[size_t(w)] < 0) component_[size_t(w)] = id, queue.push_back(w);
      }
    }
    std::sort(comp_tris_.back().begin(), comp_tris_.back().end());
  }
  // Drop components without area; cumulative areas; seeds.
  std::vector<std::vector<int32_t>> kept;
  for (auto& tris : comp_tris_) {
    double acc = 0;
    std::vector<double> cdf;
    for (int32_t t : tris) cdf.push_back(acc += area_[size_t(t)]);
    if (!(acc > 0)) continue;
    comp_cdf_.push_back(std::move(cdf));
    kept.push_back(std::move(tris));
  }
  comp_tris_.swap(kept);
  component_.assign(size_t(T), -1);
  for (size_t c = 0; c < comp_tris_.size(); ++c)
    for (int32_t t : comp_tris_[c]) component_[size_t(t)] = int32_t(c);
  stats_.components = int32_t(comp_tris_.size());
  comp_seeds_.assign(comp_tris_.size(), {});
  for (const SurfacePoint& s : p_.seeds) {
    const int32_t c = component_[size_t(s.triangle)];
    if (c < 0) continue;
    SurfacePoint q{s.triangle, std::max(s.b1, 0.0), std::max(s.b2, 0.0)};
    if (q.b1 + q.b2 > 1) {
      const double sum = q.b1 + q.b2;
      q.b1 /= sum, q.b2 /= sum;
    }
    comp_seeds_[size_t(c)].push_back(q);
  }
  for (size_t c = 0; c < comp_tris_.size(); ++c) {
    if (!comp_seeds_[c].empty()) continue;
    throw_if_cancelled(p_.cancel);
    V3 centroid;
    double total_c = 0;
    for (int32_t t : comp_tris_[c]) {
      const int32_t* k = in_.triangles + 3 * size_t(t);
      const V3 mid = (mesh_position(in_, k[0]) + mesh_position(in_, k[1]) + mesh_position(in_, k[2])) * (1.0 / 3);
      centroid = centroid + mid * area_[size_t(t)];
      total_c += area_[size_t(t)];
    }
    centroid = centroid * (1 / total_c);
    // The component's point nearest the centroid (first triangle on ties), per triangle in parallel.
    const std::vector<int32_t>& tris = comp_tris_[c];
    std::vector<std::pair<double, SurfacePoint>> nearest(tris.size());
    tbb::parallel_for(tbb::blocked_range<size_t>(0, tris.size(), 2048), [&](const tbb::blocked_range<size_t>& r) {
      throw_if_cancelled(p_.cancel);
      for (size_t i = r.begin(); i < r.end(); ++i) {
        const int32_t t = tris[i];
        const int32_t* k = in_.triangles + 3 * size_t(t);
        const V3 p0 = mesh_position(in_, k[0]), e1 = mesh_position(in_, k[1]) - p0, e2 = mesh_position(in_, k[2]) - p0;
        const V3 q = centroid - p0, n = cross(e1, e2);
        const double n2 = dot(n, n);
        double b1 = dot(cross(q, e2), n) / n2, b2 = dot(cross(e1, q), n) / n2;
        if (b1 < 0 || b2 < 0 || b1 + b2 > 1) {  // outside: the nearest point of the three edges
          const V3 corners[3] = {p0, p0 + e1, p0 + e2};
          double best_e = std::numeric_limits<double>::infinity();
          for (int e = 0; e < 3; ++e) {
            const V3 a = corners[e], d = corners[(e + 1) % 3] - a;
            const double s = std::clamp(dot(centroid - a, d) / dot(d, d), 0.0, 1.0);
            const V3 x = a + d * s;
            const double dd = dot(centroid - x, centroid - x);
            if (dd >= best_e) continue;
            best_e = dd;
            double w[3] = {0, 0, 0};
            w[e] = 1 - s, w[(e + 1) % 3] = s;
            b1 = w[1], b2 = w[2];
          }
        }
        const V3 x = p0 + e1 * b1 + e2 * b2;
        nearest[i] = {dot(centroid - x, centroid - x), {t, b1, b2}};
      }
    });
    size_t best = 0;
    for (size_t i = 1; i < nearest.size(); ++i)
      if (nearest[i].first < nearest[best].first) best = i;
    comp_seeds_[c].push_back(nearest[best].second);
  }
  std::vector<float> scales = p_.vertex_scale;
  if (!scales.empty()) {
    min_scale_ = *std::min_element(scales.begin(), scales.end());
    std::nth_element(scales.begin(), scales.begin() + ptrdiff_t(scales.size() / 2), scales.end());
    median_scale_ = scales[scales.size() / 2];
  }
}

std::vector<int32_t> Placer::class_order() const {
  if (!p_.classes.empty()) return p_.classes;
  std::vector<int32_t> order;
  for (int32_t k = 0; k < a_.num_classes; ++k)
    if (k != a_.background && a_.classes[size_t(k)].has_complete) order.push_back(k);
  std::stable_sort(order.begin(), order.end(), [&](int32_t u, int32_t v) {
    return a_.classes[size_t(u)].particles > a_.classes[size_t(v)].particles;
  });
  if (order.empty()) refuse("the analysis has no class with a complete particle to place");
  return order;
}

ClassPlan Placer::plan_class(int32_t k) const {
  ClassPlan cp;
  cp.id = k;
  const ParticleClass& cls = a_.classes[size_t(k)];
  cp.tolerance = cls.tolerance;
  cp.density_px = cls.density;
  cp.min_distance_px = cls.min_distance;
  double box_sum = 0, spacing_sum = 0;
  int64_t spacing_n = 0;
  for (const Particle& P : a_.particles) {
    if (P.class_id != k || !P.complete) continue;
    cp.complete.push_back(P.id);
    box_sum += 4.0 * P.box.half_x * P.box.half_y;
    cp.max_radius_px = std::max(cp.max_radius_px, std::hypot(double(P.box.half_x), double(P.box.half_y)));
    const int32_t b = a_.cooc_start[size_t(P.id)], e = a_.cooc_start[size_t(P.id) + 1];
    if (e > b) cp.lists.push_back(P.id);
    for (int32_t i = b; i < e; ++i) {
      const CoOccurrence& c = a_.cooc[size_t(i)];
      if (c.source != EntrySource::kMeasured || c.neighbour < 0 || c.neighbour >= int32_t(a_.particles.size()))
        continue;
      const ParticleBox& q = a_.particles[size_t(c.neighbour)].box;
      const double cs = std::abs(std::cos(double(c.angle))), sn = std::abs(std::sin(double(c.angle)));
      const double u = P.box.half_x + c.dx + q.half_x * cs + q.half_y * sn;
      const double v = P.box.half_y + c.dy + q.half_x * sn + q.half_y * cs;
      spacing_sum += std::hypot(u, v), ++spacing_n;
    }
  }
  if (cp.complete.empty()) refuse("class " + std::to_string(k) + " has no complete particle (nothing to place)");
  cp.mean_box_px = std::max(box_sum / double(cp.complete.size()), 1e-6);
  cp.spacing_px = spacing_n > 0 ? spacing_sum / double(spacing_n)
                                : std::sqrt(double(a_.width) * a_.height / std::max(1, cls.particles));
  cp.random = cls.random || cp.lists.empty();
  cp.margin_px = a_.class_pair(k, k).margin;  // half the class's 10th-percentile nearest box gap
  return cp;
}

// kPlacementCapFactor x the expected count: area over box area under the local pixel, size, density.
int64_t Placer::class_cap(const ClassPlan& cp) const {
  std::vector<double> per(size_t(in_.num_triangles), 0.0);
  parallel_triangles([&](int32_t t) {
    if (area_[size_t(t)] <= 0) return;
    const Local l = local({t, 1.0 / 3, 1.0 / 3}, V3{0, 0, 1});
    if (l.empty()) return;
    const double box = cp.mean_box_px * (l.pixel * l.size) * (l.pixel * l.size);
    per[size_t(t)] = area_[size_t(t)] * l.density / box;
  });
  double expected = 0;
  for (double e : per) expected += e;  // fixed order
  const double cap = kPlacementCapFactor * expected + 16 + double(comp_tris_.size());
  return cap < double(std::numeric_limits<int64_t>::max() / 2) ? int64_t(std::ceil(cap))
                                                               : std::numeric_limits<int64_t>::max() / 2;
}

// --------------------------------------------------------------------------------------- geometry

Local Placer::local(const SurfacePoint& sp, V3 fallback_up) const {
  Local l;
  const int32_t* c = in_.triangles + 3 * size_t(sp.triangle);
  const double w[3] = {1 - sp.b1 - sp.b2, sp.b1, sp.b2};
  l.position = surface_position(in_, sp);
  l.normal = smooth_normal(m_.walk, in_, sp);
  V3 d;
  double m = 0;
  for (int k = 0; k < 3; ++k) {
    d = d + v3(&p_.directions[3 * size_t(c[k])]) * w[k];
    m += (p_.vertex_scale.empty() ? 1.0 : double(p_.vertex_scale[size_t(c[k])])) * w[k];
  }
  V3 up = project_to_plane(d, l.normal);
  if (!(norm(up) >= kPlacementFieldZero)) up = project_to_plane(fallback_up, l.normal);
  l.up = normalized_or(up, any_perpendicular(l.normal));
  l.right = normalized_or(cross(l.up, l.normal), any_perpendicular(l.normal));
  l.up = cross(l.normal, l.right);
  l.pixel = p_.sample_world_width / double(a_.width) / std::max(m, min_scale_);
  const size_t t = size_t(sp.triangle);
  auto clamped = [](double v) { return v <= 0 ? 0.0 : std::clamp(v, kPlacementMinOverride, kPlacementMaxOverride); };
  if (!p_.face_density.empty()) l.density = clamped(p_.face_density[t]);
  if (!p_.face_size.empty()) l.size = clamped(p_.face_size[t]);
  if (!p_.face_probability.empty()) l.probability = p_.face_probability[t];
  return l;
}

SurfacePoint Placer::random_point(const std::vector<int32_t>& tris, const std::vector<double>& cdf, Rng& rng) const {
  const double r = rng.uniform() * cdf.back();
  const size_t i = std::min(size_t(std::upper_bound(cdf.begin(), cdf.end(), r) - cdf.begin()), tris.size() - 1);
  double b1 = rng.uniform(), b2 = rng.uniform();
  if (b1 + b2 > 1) b1 = 1 - b1, b2 = 1 - b2;
  return {tris[i], b1, b2};
}

Placed Placer::make(const SurfacePoint& at, const Local& l, int32_t sprite, double theta, double jitter,
                    double margin) const {
  Placed c;
  c.at = at;
  c.l = l;
  c.sprite = sprite;
  c.theta = fold_half_turn(theta);
  c.axis = l.right * std::cos(c.theta) + l.up * std::sin(c.theta);
  c.unit = l.pixel * l.size * jitter;
  const ParticleBox& box = a_.particles[size_t(sprite)].box;
  c.half_x = box.half_x * c.unit, c.half_y = box.half_y * c.unit;
  c.reach = 1 / std::sqrt(std::max(l.density, kPlacementMinOverride));
  c.ex_x = c.reach * (c.half_x + margin * l.pixel), c.ex_y = c.reach * (c.half_y + margin * l.pixel);
  c.bound = std::hypot(c.ex_x, c.ex_y);
  c.bound_all = c.reach * std::hypot(c.half_x + max_margin_px_ * l.pixel, c.half_y + max_margin_px_ * l.pixel);
  c.cls = a_.particles[size_t(sprite)].class_id;
  return c;
}

// Against the placed particles with index >= from: those of the class by its own rules (every one), those of
// other classes by the pair's (only the output ones: a particle hidden by probability or density leaves the
// room it held to the other classes, as the sample's gaps between particles of one class hold the others).
bool Placer::conflicts(const Placed& c, const ClassPlan& cp, int32_t from) const {
  const V3 v = cross(c.l.normal, c.axis);
  const double bx = c.reach * c.half_x, by = c.reach * c.half_y;
  bool hit = false;
  all_.near(c.l.position, c.bound_all + all_.max_radius, [&](int32_t j) {
    if (j < from) return false;
    const Placed& o = placed_[size_t(j)];
    const bool same = o.cls == c.cls;
    if (!same && !o.visible) return false;
    if (dot(o.l.normal, c.l.normal) < 0) return false;  // two sides of a thin part
    const V3 d = o.l.position - c.l.position;
    const double reach = c.bound_all + o.bound_all;
    if (dot(d, d) >= reach * reach) return false;
    // Tolerance, and both boxes grown by the margin (the class's own, or the pair's), scaled like the offsets.
    double tolerance = cp.tolerance, cx = c.ex_x, cy = c.ex_y, gx = o.ex_x, gy = o.ex_y;
    if (!same) {
      const ParticleClassPair& pair = a_.class_pair(c.cls, o.cls);
      tolerance = pair.tolerance;
      cx = c.reach * (c.half_x + pair.margin * c.l.pixel), cy = c.reach * (c.half_y + pair.margin * c.l.pixel);
      gx = o.reach * (o.half_x + pair.margin * o.l.pixel), gy = o.reach * (o.half_y + pair.margin * o.l.pixel);
    }
    const double ox = dot(o.axis, c.axis), oy = dot(o.axis, v), len = std::hypot(ox, oy);
    const double ux = len > 1e-9 ? ox / len : 1, uy = len > 1e-9 ? oy / len : 0, px = dot(d, c.axis), py = dot(d, v);
    // The grown boxes hold the boxes: apart, nothing overlaps.
    if (boxes_apart({0, 0, 1, 0, cx, cy}, {px, py, ux, uy, gx, gy})) return false;
    // The boxes (scaled like the offsets) may overlap up to the tolerance...
    const double qx = o.reach * o.half_x, qy = o.reach * o.half_y;
    const double smaller = std::min(4 * bx * by, 4 * qx * qy);
    if (smaller > 0 && box_overlap_area({0, 0, 1, 0, bx, by}, {px, py, ux, uy, qx, qy}) > tolerance * smaller)
      return hit = true;
    // ...and the boxes grown by half the least gap must stay apart.
    if (cx == bx && cy == by) return false;
    const double grown = std::min(4 * cx * cy, 4 * gx * gy);
    hit = box_overlap_area({0, 0, 1, 0, cx, cy}, {px, py, ux, uy, gx, gy}) > kPlacementGrownTolerance * grown;
    return hit;
  });
  return hit;
}

bool Placer::any_within(const ClassGrid& g, V3 p, V3 n, double radius) const {
  bool hit = false;
  g.near(p, radius, [&](int32_t j) {
    const Placed& o = placed_[size_t(j)];
    const V3 d = o.l.position - p;
    hit = dot(o.l.normal, n) >= 0 && dot(d, d) < radius * radius;
    return hit;
  });
  return hit;
}

// ------------------------------------------------------------------------------------------ classes

bool Placer::accept(ClassRun& run, Placed&& c) {
  if (run.stop) return false;
  c.visible = run.rng.uniform() < c.l.probability;  // drawn for every placed particle: same streams for any p
  const int32_t index = int32_t(placed_.size());
  run.grid.insert(index, c.l.position, c.radius());
  all_.insert(index, c.l.position, c.bound_all);
  (c.visible ? run.st.placed : run.st.hidden)++;
  if (c.origin == uint8_t(PlacementOrigin::seed)) run.st.seeds++;
  if (c.origin == uint8_t(PlacementOrigin::reseeded)) run.st.reseeded++;
  placed_.push_back(std::move(c));
  ++run.count;
  if (int64_t(placed_.size()) >= p_.max_particles) global_capped_ = run.stop = true;
  if (run.count >= run.st.cap) run.st.capped = run.stop = true;
  return true;
}

// The class's particles round c, counted with a weight that falls to 0 at the rim of a disc sized to expect
// kPlacementCrowdCount of them (sample density x the local density override), and the weighted count the
// surface inside that disc expects (triangles by centroid; fewer than kPlacementCrowdTriangles inside, a
// coarse mesh: the whole disc's). A disc that leaves the surface (a boundary) expects fewer. With
// stop_factor > 0, counting stops at stop_factor x expected, and a disc that mostly leaves the surface (a
// corner: expected below kPlacementCrowdCovered x nominal) is not counted at all.
Placer::LocalCount Placer::local_count(const ClassRun& run, const Placed& c, double stop_factor) const {
  LocalCount out;
  const double radius = run.crowd_radius_px * c.l.pixel, inv_r2 = 1 / (radius * radius);
  // Weighted, a lattice's count hardly depends on where the disc sits, where a plain count in a disc
  // swings by the points on its rim (an exact grid was refused children).
  auto weight = [&](V3 d) {
    const double q = 1 - dot(d, d) * inv_r2;
    return q > 0 ? q * q : 0.0;
  };
  double surface = 0;
  int32_t inside = 0;
  run.triangles.near(c.l.position, radius, [&](int32_t t) {
    const double w = weight(tri_centre_[size_t(t)] - c.l.position);
    if (w > 0 && dot(tri_normal_[size_t(t)], c.l.normal) > 0) surface += w * tri_px_[size_t(t)], ++inside;
    return false;
  });
  out.nominal = kPlacementCrowdCount * c.l.density;
  out.expected = inside >= kPlacementCrowdTriangles ? surface * run.cp.density_px : out.nominal;
  if (stop_factor > 0 && out.expected < kPlacementCrowdCovered * out.nominal) return out;
  const double stop_at = stop_factor > 0 ? stop_factor * out.expected : std::numeric_limits<double>::infinity();
  double nearest_sq = std::numeric_limits<double>::infinity();  // one sqrt at the end: crowded() runs per child
  run.grid.near(c.l.position, radius, [&](int32_t j) {
    const Placed& o = placed_[size_t(j)];
    if (dot(o.l.normal, c.l.normal) >= 0) {
      const V3 d = o.l.position - c.l.position;
      out.weighted += weight(d);
      if (&o != &c) nearest_sq = std::min(nearest_sq, dot(d, d));
    }
    return out.weighted >= stop_at;
  });
  out.nearest = std::sqrt(nearest_sq);
  return out;
}

// Whether the class already holds (1 + kPlacementCrowdSlack) x the count the surface round c expects.
bool Placer::crowded(const ClassRun& run, const Placed& c) const {
  if (!(run.crowd_radius_px > 0)) return false;
  // A disc that mostly leaves the surface (a corner) holds too few particles for their count to mean
  // anything: an exact grid's particle on a plane's corner counted 5.2 against 4 expected and was refused.
  const LocalCount n = local_count(run, c, 1 + kPlacementCrowdSlack);
  if (n.expected < kPlacementCrowdCovered * n.nominal) return false;
  return n.weighted >= (1 + kPlacementCrowdSlack) * n.expected;
}

bool Placer::try_seed(ClassRun& run, const SurfacePoint& at, PlacementOrigin origin) {
  const int32_t sprite = run.cp.complete[run.rng.below(uint32_t(run.cp.complete.size()))];
  const double jitter = 1 + p_.size_jitter * (2 * run.rng.uniform() - 1);
  const Local l = local(at, any_perpendicular(smooth_normal(m_.walk, in_, at)));
  if (l.empty()) {
    run.st.excluded++;
    return false;
  }
  Placed c = make(at, l, sprite, a_.particles[size_t(sprite)].box.angle, jitter, run.cp.margin_px);
  c.origin = uint8_t(origin);
  if (conflicts(c, run.cp)) {
    run.st.rejected_overlap++;
    return false;
  }
  return accept(run, std::move(c));
}

void Placer::propagate(ClassRun& run, std::vector<int32_t> frontier, int32_t class_index, int32_t num_classes) {
  std::vector<Child> kids;
  std::vector<SectionWalkRequest> requests;
  std::vector<int32_t> order, next;
  const double expected = std::max(1.0, double(run.st.cap) / kPlacementCapFactor);
  while (!frontier.empty() && !run.stop) {
    throw_if_cancelled(p_.cancel);
    kids.clear();
    requests.clear();
    // Children in FIFO order, every random draw made here, sequentially.
    for (int32_t pi : frontier) {
      const int32_t list = run.cp.lists[run.rng.below(uint32_t(run.cp.lists.size()))];
      const int32_t b = a_.cooc_start[size_t(list)], e = a_.cooc_start[size_t(list) + 1];
      order.resize(size_t(e - b));
      for (int32_t i = 0; i < e - b; ++i) order[size_t(i)] = b + i;
      for (size_t i = order.size(); i > 1; --i) std::swap(order[i - 1], order[run.rng.below(uint32_t(i))]);
      for (int32_t entry : order) {
        Child ch;
        ch.parent = pi, ch.entry = entry;
        ch.sprite = run.cp.complete[run.rng.below(uint32_t(run.cp.complete.size()))];
        ch.jitter = 1 + p_.size_jitter * (2 * run.rng.uniform() - 1);
        kids.push_back(ch);
      }
    }
    // Centre offset in the parent's box frame for the child's factors `cl` (see the header), walked.
    auto request = [&](const Child& ch, const Local& cl) {
      const Placed& P = placed_[size_t(ch.parent)];
      const CoOccurrence& e = a_.cooc[size_t(ch.entry)];
      const ParticleBox& q = a_.particles[size_t(ch.sprite)].box;
      const double cs = std::abs(std::cos(double(e.angle))), sn = std::abs(std::sin(double(e.angle)));
      const double child_unit = cl.pixel * cl.size * ch.jitter, gap = 0.5 * (P.l.pixel + cl.pixel);
      const double overlap = 0.5 * (P.unit + child_unit);  // negative gaps follow the boxes
      const double squeeze = 1 / std::sqrt(0.5 * (P.l.density + cl.density));
      const double u = (P.half_x + e.dx * (e.dx < 0 ? overlap : gap) + (q.half_x * cs + q.half_y * sn) * child_unit);
      const double v = (P.half_y + e.dy * (e.dy < 0 ? overlap : gap) + (q.half_x * sn + q.half_y * cs) * child_unit);
      const double su = e.quadrant == 0 || e.quadrant == 3 ? 1 : -1, sv = e.quadrant <= 1 ? 1 : -1;
      const V3 dir = (P.axis * (su * u) + cross(P.l.normal, P.axis) * (sv * v)) * squeeze;
      return SectionWalkRequest{P.at, dir, norm(dir)};
    };
    auto walk_all = [&](const std::vector<size_t>& which, bool first) {
      requests.clear();
      std::vector<size_t> walked;
      for (size_t k : which) {
        Child& ch = kids[k];
        const SectionWalkRequest r = request(ch, first ? placed_[size_t(ch.parent)].l : ch.l);
        // A child on its parent's centre (a fully overlapping entry) would be refused anyway.
        if (!(r.length > 1e-12 * placed_[size_t(ch.parent)].l.pixel) || !std::isfinite(r.length)) {
          ch.reached = false;
          continue;
        }
        requests.push_back(r);
        walked.push_back(k);
      }
      const auto results = walk_normal_sections(m_.walk, in_, requests.data(), int64_t(requests.size()), {}, p_.cancel);
      stats_.walks += int64_t(requests.size());
      tbb::parallel_for(tbb::blocked_range<size_t>(0, walked.size(), 64), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t i = r.begin(); i < r.end(); ++i) {
          Child& ch = kids[walked[i]];
          ch.reached = results[i].status == WalkStatus::reached;
          if (!ch.reached) continue;
          ch.at = results[i].end;
          ch.l = local(ch.at, placed_[size_t(ch.parent)].l.up);
        }
      });
    };
    std::vector<size_t> all(kids.size()), again;
    for (size_t k = 0; k < kids.size(); ++k) all[k] = k;
    walk_all(all, true);
    // Walk again once where the landing point's factors differ from the parent's.
    for (size_t k = 0; k < kids.size(); ++k) {
      const Child& ch = kids[k];
      const Local& pl = placed_[size_t(ch.parent)].l;
      if (ch.reached && !ch.l.empty() &&
          (std::abs(ch.l.pixel - pl.pixel) > 1e-9 * pl.pixel || ch.l.size != pl.size || ch.l.density != pl.density))
        again.push_back(k);
    }
    if (!again.empty()) walk_all(again, false);
    // Conflicts with earlier generations do not depend on the order: tested in parallel (the grid is
    // only read); those with this generation's particles one by one below.
    const int32_t generation = int32_t(placed_.size());
    tbb::parallel_for(tbb::blocked_range<size_t>(0, kids.size(), 64), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t k = r.begin(); k < r.end(); ++k) {
        Child& ch = kids[k];
        if (!ch.reached || ch.l.empty()) continue;
        ch.refused = conflicts(child_particle(ch), run.cp);
      }
    });
    // Accept one by one, in order.
    next.clear();
    for (size_t k = 0; k < kids.size() && !run.stop; ++k) {
      if (k % kCancelEvery == 0) throw_if_cancelled(p_.cancel);
      const Child& ch = kids[k];
      if (!ch.reached) {
        run.st.walls++;
        continue;
      }
      if (ch.l.empty()) {
        run.st.excluded++;
        continue;
      }
      Placed c = child_particle(ch);
      if (ch.refused || conflicts(c, run.cp, generation)) {
        run.st.rejected_overlap++;
        continue;
      }
      if (crowded(run, c)) {
        run.st.crowded++;
        continue;
      }
      if (accept(run, std::move(c))) next.push_back(int32_t(placed_.size()) - 1);
    }
    frontier.swap(next);
    report(class_index, num_classes, double(run.count) / expected);
  }
}

// Where darts may land: every triangle of a component with particles allowed, weighted by area x density /
// pixel area (summed in triangle order: the surface in sample pixels^2).
void Placer::prepare_darts() {
  std::vector<double> per(size_t(in_.num_triangles), -1.0);  // -1: no particle there
  parallel_triangles([&](int32_t t) {
    if (component_[size_t(t)] < 0) return;
    const Local l = local({t, 1.0 / 3, 1.0 / 3}, V3{0, 0, 1});
    if (!l.empty()) per[size_t(t)] = area_[size_t(t)] * l.density / (l.pixel * l.pixel);
  });
  tri_px_.assign(size_t(in_.num_triangles), 0.0);
  tri_centre_.assign(size_t(in_.num_triangles), V3{});
  tri_normal_.assign(size_t(in_.num_triangles), V3{});
  parallel_triangles([&](int32_t t) {
    const int32_t* k = in_.triangles + 3 * size_t(t);
    const V3 a = mesh_position(in_, k[0]), b = mesh_position(in_, k[1]), c = mesh_position(in_, k[2]);
    tri_centre_[size_t(t)] = (a + b + c) * (1.0 / 3);
    tri_normal_[size_t(t)] = normalized_or(cross(b - a, c - a), V3{0, 0, 1});
    tri_px_[size_t(t)] = std::max(per[size_t(t)], 0.0);
  });
  double acc = 0;
  for (int32_t t = 0; t < in_.num_triangles; ++t) {  // fixed order
    if (per[size_t(t)] < 0) continue;
    dart_tris_.push_back(t);
    dart_cdf_.push_back(acc += per[size_t(t)]);
  }
  surface_px_ = acc;
}

// Up to `target` particles by dart throwing (at most 30 x target + 64 darts; filling a class, also stopping
// after kPlacementFillMisses darts in a row found no room), each at least the class's minimum distance from
// its own class (scaled like gaps) and not in conflict with any placed particle.
int64_t Placer::darts(ClassRun& run, int64_t target, PlacementOrigin origin) {
  if (dart_tris_.empty() || !(surface_px_ > 0) || target <= 0) return 0;
  const int64_t darts = 30 * target + 64;
  const bool filling = origin == PlacementOrigin::filled;
  int64_t got = 0, misses = 0;
  for (int64_t i = 0; i < darts && got < target && !run.stop; ++i) {
    if (i % kCancelEvery == 0) throw_if_cancelled(p_.cancel);
    if (filling && misses >= kPlacementFillMisses) break;
    const SurfacePoint at = random_point(dart_tris_, dart_cdf_, run.rng);
    const Local l = local(at, V3{0, 0, 1});
    const double gap = run.cp.min_distance_px * l.pixel / std::sqrt(std::max(l.density, kPlacementMinOverride));
    const bool placed = !any_within(run.grid, l.position, l.normal, gap) && try_seed(run, at, origin);
    got += placed;
    misses = placed ? 0 : misses + 1;
  }
  return got;
}

void Placer::run_random(ClassRun& run) {
  const double draw = std::floor(run.cp.density_px * surface_px_ + run.rng.uniform());
  darts(run, draw < double(run.st.cap) ? int64_t(draw) : run.st.cap, PlacementOrigin::random_class);
}

// Density (issue 30): the propagation fills every gap an irregular arrangement leaves, so it packs such a
// class closer than the sample (60 pebbles per 256^2 at random: 1.4-1.9 x the field's count). When a class
// holds more than (1 + kPlacementDensitySlack) x its expected count (the sample's density over the surface
// in sample pixels), particles chosen uniformly from its stream are hidden until it holds the expected
// count; they stay in its arrangement (they still keep its particles apart) but leave their room to later
// classes.
void Placer::thin(ClassRun& run, size_t first) {
  const double expected = run.cp.density_px * surface_px_;
  const size_t n = placed_.size() - first;
  if (global_capped_ || !(double(n) > (1 + kPlacementDensitySlack) * expected) || n >= (size_t(1) << 32)) return;
  const size_t drop = n - size_t(std::llround(expected));
  // Where the propagation packed more than elsewhere (round its seeds; a boundary it could not fill),
  // more go: particle i is kept with a chance that falls as its local count ratio rises (weighted sampling
  // without replacement, keys -ln(u) x ratio^kPlacementThinExponent x closeness, largest dropped). A uniform
  // choice kept the excess where it was: the middle of a plane 3 samples wide held 1.18 x the sample's density.
  std::vector<double> ratio(n, 1.0), nearest(n, 0.0);
  if (run.crowd_radius_px > 0)
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 256), [&](const tbb::blocked_range<size_t>& r) {
      throw_if_cancelled(p_.cancel);
      for (size_t i = r.begin(); i < r.end(); ++i) {
        const LocalCount lc = local_count(run, placed_[first + i], 0.0);
        ratio[i] = lc.weighted / std::max(lc.expected, kPlacementCrowdCovered * lc.nominal);
        const Local& l = placed_[first + i].l;  // sample pixels at the local scale and density
        nearest[i] = lc.nearest / l.pixel * std::sqrt(std::max(l.density, kPlacementMinOverride));
      }
    });
  // A particle nearer a same-class neighbour than the sample's classes ever are (the class's min distance,
  // 0.7 x its mean nearest-neighbour distance) goes sooner: the propagation's excess is made of gap-fillers,
  // and a random choice among them kept pairs closer than the sample has (gravel's nearest-neighbour
  // distances 0.87 x the sample's at the median). Only those: weighting every particle by its distance
  // spread the rest more evenly than a jittered lattice sample is.
  const double close_px = run.cp.min_distance_px;
  std::vector<std::pair<double, uint32_t>> key(n);
  for (size_t i = 0; i < n; ++i) {
    const double u = (double(run.rng.next_u32()) + 0.5) * (1.0 / 4294967296.0);  // (0, 1)
    const double close =
        nearest[i] < close_px ? std::pow(close_px / std::max(nearest[i], 1e-3 * close_px), kPlacementThinSpread) : 1.0;
    key[i] = {-std::log(u) * std::pow(ratio[i], kPlacementThinExponent) * close, uint32_t(i)};
  }
  std::nth_element(key.begin(), key.begin() + std::ptrdiff_t(drop), key.end(), std::greater<>());
  for (size_t k = 0; k < drop; ++k) {
    Placed& c = placed_[first + key[k].second];
    (c.visible ? run.st.placed : run.st.hidden)--;  // hidden: by the probability override
    c.visible = false;
    run.st.thinned++;
  }
}

PlacedParticles Placer::run() {
  const auto t0 = std::chrono::steady_clock::now();
  validate();
  throw_if_cancelled(p_.cancel);
  prepare_mesh();
  const std::vector<int32_t> order = class_order();
  // Output classes; the classes after the last of them cannot change them and are not placed.
  output_.assign(size_t(a_.num_classes), p_.output_classes.empty() ? 1 : 0);
  int32_t last = int32_t(order.size()) - 1;
  if (!p_.output_classes.empty()) {
    last = -1;
    for (int32_t k : p_.output_classes) {
      const auto at = std::find(order.begin(), order.end(), k);
      if (at == order.end()) {
        std::string placed;
        for (int32_t c : order) placed += (placed.empty() ? "" : ", ") + std::to_string(c);
        refuse("output class " + std::to_string(k) + " is not placed (placed classes: " + placed + ")");
      }
      if (output_[size_t(k)]++) refuse("output class " + std::to_string(k) + " is listed twice");
      last = std::max(last, int32_t(at - order.begin()));
    }
  }
  std::vector<ClassPlan> plans;
  for (int32_t ci = 0; ci <= last; ++ci) plans.push_back(plan_class(order[size_t(ci)]));
  for (const ClassPlan& u : plans)
    for (const ClassPlan& w : plans) max_margin_px_ = std::max(max_margin_px_, a_.class_pair(u.id, w.id).margin);
  const double extent = std::max({upper_.x - lower_.x, upper_.y - lower_.y, upper_.z - lower_.z, 1e-30});
  // Cells twice as wide as the largest exclusion box at the median scale, so that a conflict query
  // (radius: two half diagonals) touches at most 2 cells per axis; never 2^19 across the mesh.
  const double unit = p_.sample_world_width / a_.width / median_scale_;
  auto cell_for = [&](double radius_px, double margin_px) {
    return std::max(4 * std::hypot(radius_px + margin_px, margin_px) * unit, extent / double(int64_t(1) << 19));
  };
  all_.origin = lower_;
  all_.cell = 0;
  for (const ClassPlan& cp : plans) all_.cell = std::max(all_.cell, cell_for(cp.max_radius_px, max_margin_px_));
  prepare_darts();
  for (int32_t ci = 0; ci <= last && !global_capped_; ++ci) {
    const ClassPlan& cp = plans[size_t(ci)];
    stats_.classes.emplace_back();
    ClassPlacementStats& st = stats_.classes.back();
    st.class_id = cp.id;
    st.random = cp.random;
    st.cap = class_cap(cp);
    st.expected = cp.density_px * surface_px_;
    ClassRun run{cp, st, Rng(hash_combine(p_.seed, kClassStreamSalt), uint64_t(cp.id) + 1), {}, {}};
    margin_px_ = cp.margin_px;
    run.grid.cell = cell_for(cp.max_radius_px, cp.margin_px);
    run.grid.origin = lower_;
    if (cp.density_px > 0) {
      // The weight's integral over the disc is a third of its area.
      run.crowd_radius_px = std::sqrt(3 * kPlacementCrowdCount / (kPi * cp.density_px));
      run.triangles.cell = std::max(2 * run.crowd_radius_px * unit, extent / double(int64_t(1) << 19));
      run.triangles.origin = lower_;
      for (int32_t t : dart_tris_) run.triangles.insert(t, tri_centre_[size_t(t)], 0.0);
    }
    report(ci, last + 1, 0);
    const size_t first = placed_.size();
    if (cp.random) {
      run_random(run);
    } else {
      std::vector<int32_t> frontier;
      for (const auto& seeds : comp_seeds_)
        for (const SurfacePoint& s : seeds)
          if (try_seed(run, s, PlacementOrigin::seed)) frontier.push_back(int32_t(placed_.size()) - 1);
      propagate(run, std::move(frontier), ci, last + 1);
      // Re-seed uncovered areas until a round of tries finds none.
      while (!run.stop) {
        std::vector<int32_t> fresh;
        for (size_t c = 0; c < comp_tris_.size() && !run.stop; ++c) {
          throw_if_cancelled(p_.cancel);
          for (int k = 0; k < kPlacementReseedTries && !run.stop; ++k) {
            const SurfacePoint at = random_point(comp_tris_[c], comp_cdf_[c], run.rng);
            const Local l = local(at, V3{0, 0, 1});
            if (l.empty()) continue;
            const double reach = kPlacementReseedGaps * cp.spacing_px * l.pixel / std::sqrt(l.density);
            if (any_within(run.grid, l.position, l.normal, reach)) continue;
            if (try_seed(run, at, PlacementOrigin::reseeded)) fresh.push_back(int32_t(placed_.size()) - 1);
          }
        }
        if (fresh.empty()) break;
        st.reseed_rounds++;
        propagate(run, std::move(fresh), ci, last + 1);
      }
      // Below its expected count (other classes took its room, or its lattice could not close): darts.
      const double missing = st.expected - double(placed_.size() - first);
      if (!global_capped_ && missing > kPlacementDensitySlack * st.expected)
        st.filled = darts(run, std::llround(missing), PlacementOrigin::filled);
    }
    thin(run, first);
  }
  stats_.capped = global_capped_;
  PlacedParticles out = output();
  out.stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (p_.progress) p_.progress->store(1.f);
  return out;
}

PlacedParticles Placer::output() const {
  PlacedParticles out;
  std::vector<int32_t> row(placed_.size(), -1);
  for (size_t i = 0; i < placed_.size(); ++i) {
    const Placed& c = placed_[i];
    if (!c.visible || !output_[size_t(c.cls)]) continue;
    row[i] = int32_t(out.class_id.size());
    int32_t parent = c.parent;  // nearest output ancestor
    while (parent >= 0 && row[size_t(parent)] < 0) parent = placed_[size_t(parent)].parent;
    const Particle& s = a_.particles[size_t(c.sprite)];
    const double turn = fold_half_turn(c.theta - double(s.box.angle));
    const V3 sprite_axis = c.l.right * std::cos(turn) + c.l.up * std::sin(turn);
    out.class_id.push_back(s.class_id);
    out.sprite.push_back(c.sprite);
    out.parent.push_back(parent >= 0 ? row[size_t(parent)] : -1);
    out.triangle.push_back(c.at.triangle);
    out.barycentric.insert(out.barycentric.end(), {c.at.b1, c.at.b2});
    auto put = [](std::vector<float>& dst, V3 v) { dst.insert(dst.end(), {float(v.x), float(v.y), float(v.z)}); };
    put(out.position, c.l.position);
    put(out.normal, c.l.normal);
    put(out.sprite_axis, sprite_axis);
    out.pixel_size.push_back(float(c.unit));
    out.angle.push_back(float(c.theta));
    out.origin.push_back(c.origin);
  }
  out.stats = stats_;
  out.stats.classes.clear();
  for (const ClassPlacementStats& st : stats_.classes)
    if (output_[size_t(st.class_id)]) out.stats.classes.push_back(st);
  return out;
}

}  // namespace

PlacedParticles place_particles(const ParticleAnalysis& analysis, const SurfaceWalkMesh& mesh,
                                const PlacementParams& params) {
  return Placer(analysis, mesh, params).run();
}

}  // namespace texsynth
