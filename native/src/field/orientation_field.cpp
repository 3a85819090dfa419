// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/field/orientation_field.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "texsynth/common/errors.hpp"
#include "texsynth/mesh/vec_math.hpp"

namespace texsynth {
namespace {

constexpr double kParallelTolerance = 1e-4;  // |tangent part| / |vector| below this = "parallel to n"

template <class F>
void parallel_vertices(int32_t n, F&& f) {
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, n, 8192), [&](const tbb::blocked_range<int32_t>& r) {
    for (int32_t v = r.begin(); v < r.end(); ++v) f(v);
  });
}

// normalized_or with the fallback computed only when it is needed: the fallbacks (axis projections,
// square roots) are rarely used, and evaluating them eagerly for every vertex and every smoothing
// iteration was a large share of a relaxation. Same results as normalized_or.
template <class Fallback>
V3 normalized_or_else(V3 a, Fallback&& fallback, double min_len = 1e-12) {
  double len = norm(a);
  return len > min_len && std::isfinite(len) ? a * (1.0 / len) : fallback();
}

struct Context {
  const Mesh& mesh;
  V3 axis, fallback_axis;
  V3 normal(int32_t v) const { return v3(&mesh.normals[3 * size_t(v)]); }
  V3 position(int32_t v) const { return v3(mesh.positions + 3 * size_t(v)); }
  V3 axis_direction(int32_t v) const {
    V3 n = normal(v);
    V3 t = project_to_plane(axis, n);
    auto perpendicular = [&] { return any_perpendicular(n); };
    if (norm(t) > kParallelTolerance) return normalized_or_else(t, perpendicular);
    return normalized_or_else(project_to_plane(fallback_axis, n), perpendicular, kParallelTolerance);
  }
};

void check_vertex(const Mesh& m, int32_t v, const char* what, size_t i) {
  if (v < 0 || v >= m.num_vertices)
    throw std::invalid_argument(std::string(what) + "[" + std::to_string(i) + "] = " + std::to_string(v) +
                                " is not a vertex index (mesh has " + std::to_string(m.num_vertices) + " vertices)");
}

// Multi-source breadth-first walk from `roots` (in the given order, so the result is deterministic).
// visit(child, parent) is called once per reached non-root vertex, parents before children.
template <class Visit>
void bfs(const Mesh& m, const std::vector<int32_t>& roots, std::vector<float>& path_length, Visit&& visit) {
  std::vector<int32_t> queue;
  queue.reserve(m.num_vertices);
  path_length.assign(m.num_vertices, -1.f);
  for (int32_t r : roots)
    if (path_length[r] < 0) path_length[r] = 0.f, queue.push_back(r);
  for (size_t head = 0; head < queue.size(); ++head) {
    int32_t v = queue[head];
    V3 pv = v3(m.positions + 3 * size_t(v));
    for (int32_t k = m.neighbour_start[v]; k < m.neighbour_start[v + 1]; ++k) {
      int32_t w = m.neighbours[k];
      if (path_length[w] >= 0) continue;
      path_length[w] = path_length[v] + float(norm(v3(m.positions + 3 * size_t(w)) - pv));
      visit(w, v);
      queue.push_back(w);
    }
  }
}

}  // namespace

OrientationMode parse_orientation_mode(const std::string& name) {
  if (name == "axis") return OrientationMode::Axis;
  if (name == "anchors") return OrientationMode::Anchors;
  if (name == "field") return OrientationMode::Field;
  throw std::invalid_argument("orientation must be 'axis', 'anchors' or 'field', not '" + name + "'");
}

std::vector<float> compute_orientation_field(const Mesh& m, const FieldParams& p) {
  const int32_t nv = m.num_vertices;
  V3 axis = v3(p.axis);
  if (!std::isfinite(axis.x) || !std::isfinite(axis.y) || !std::isfinite(axis.z) || norm(axis) < 1e-12)
    throw std::invalid_argument("orientation axis must be a finite non-zero vector");
  axis = axis * (1.0 / norm(axis));
  Context ctx{m, axis, std::fabs(axis.x) > 0.9 ? V3{0, 1, 0} : V3{1, 0, 0}};

  // --- validate everything before computing anything
  if (p.anchor_vertices.size() != p.anchor_directions.size())
    throw std::invalid_argument("anchor_vertices and anchor_directions must have the same length (" +
                                std::to_string(p.anchor_vertices.size()) + " vs " +
                                std::to_string(p.anchor_directions.size()) + ")");
  for (size_t i = 0; i < p.anchor_vertices.size(); ++i) check_vertex(m, p.anchor_vertices[i], "anchor_vertices", i);
  for (size_t i = 0; i < p.sources.size(); ++i) check_vertex(m, p.sources[i], "sources", i);
  for (size_t i = 0; i < p.sinks.size(); ++i) check_vertex(m, p.sinks[i], "sinks", i);
  if (p.smoothing_iterations < 0 || p.smoothing_iterations > 10000)
    throw std::invalid_argument("smoothing_iterations must be in [0, 10000]");
  std::vector<V3> anchors(p.anchor_vertices.size());
  for (size_t i = 0; i < anchors.size(); ++i) {
    V3 d = v3(p.anchor_directions[i]);
    if (!std::isfinite(d.x) || !std::isfinite(d.y) || !std::isfinite(d.z))
      throw std::invalid_argument("anchor_directions[" + std::to_string(i) + "] is NaN or infinite");
    V3 t = project_to_plane(d, ctx.normal(p.anchor_vertices[i]));
    if (norm(t) <= kParallelTolerance * norm(d) || norm(t) < 1e-30)
      throw std::invalid_argument("anchor_directions[" + std::to_string(i) + "] is zero or parallel to the normal of vertex " +
                                  std::to_string(p.anchor_vertices[i]));
    anchors[i] = t * (1.0 / norm(t));
  }
  if (p.mode == OrientationMode::Field && !p.direction)
    throw std::invalid_argument("orientation='field' needs a per-vertex direction array");
  if (p.mode == OrientationMode::Anchors && anchors.empty() && p.sources.empty() && p.sinks.empty())
    throw std::invalid_argument("orientation='anchors' needs anchor_vertices/anchor_directions, sources or sinks");

  throw_if_cancelled(p.cancel);
  std::vector<float> out(size_t(nv) * 3);
  if (p.mode == OrientationMode::Axis) {
    parallel_vertices(nv, [&](int32_t v) { store(&out[3 * size_t(v)], ctx.axis_direction(v)); });
    throw_if_cancelled(p.cancel);
    return out;
  }

  // --- fixed vectors: the caller's set field vectors, then anchors (anchors win)
  std::vector<char> fixed(nv, 0);
  std::vector<int32_t> fixed_list;
  if (p.mode == OrientationMode::Field) {
    for (int32_t v = 0; v < nv; ++v) {
      V3 d = v3(p.direction + 3 * size_t(v));
      if (!std::isfinite(d.x) || !std::isfinite(d.y) || !std::isfinite(d.z))
        throw std::invalid_argument("direction of vertex " + std::to_string(v) + " is NaN or infinite");
      V3 t = project_to_plane(d, ctx.normal(v));
      if (norm(t) > kParallelTolerance * norm(d) && norm(t) > 1e-30) {
        store(&out[3 * size_t(v)], t * (1.0 / norm(t)));
        fixed[v] = 1;
        fixed_list.push_back(v);
      }
    }
  }
  for (size_t i = 0; i < anchors.size(); ++i) {
    int32_t v = p.anchor_vertices[i];
    store(&out[3 * size_t(v)], anchors[i]);
    if (!fixed[v]) fixed[v] = 1, fixed_list.push_back(v);
  }

  throw_if_cancelled(p.cancel);
  // --- transport fixed vectors outward
  std::vector<float> anchor_length;
  bfs(m, fixed_list, anchor_length, [&](int32_t w, int32_t parent) {
    V3 carried = project_to_plane(v3(&out[3 * size_t(parent)]), ctx.normal(w));
    store(&out[3 * size_t(w)], normalized_or_else(carried, [&] { return ctx.axis_direction(w); }));
  });

  throw_if_cancelled(p.cancel);
  // --- singularities: away from sources, toward sinks, along BFS paths
  if (!p.sources.empty() || !p.sinks.empty()) {
    std::vector<int32_t> roots(p.sources);
    roots.insert(roots.end(), p.sinks.begin(), p.sinks.end());
    std::vector<float> flow(size_t(nv) * 3, 0.f);  // unsigned "away from root" direction
    std::vector<signed char> sign(nv, 0);
    std::vector<int32_t> root(nv, -1);
    for (int32_t s : p.sinks) sign[s] = -1, root[s] = s;
    for (int32_t s : p.sources) sign[s] = 1, root[s] = s;  // a vertex listed as both counts as a source
    std::vector<float> singular_length;
    bfs(m, roots, singular_length, [&](int32_t w, int32_t parent) {
      // The chord from the root, projected on the tangent plane, is the exact away-direction on
      // planes and spheres; where it is nearly normal (folded surfaces) trust the BFS-transported
      // direction instead, in proportion.
      V3 n = ctx.normal(w);
      root[w] = root[parent];
      sign[w] = sign[parent];
      V3 chord = ctx.position(w) - ctx.position(root[w]);
      V3 tangent = project_to_plane(chord, n);
      double chord_len = norm(chord), tangent_len = norm(tangent);
      double trust = chord_len > 0 ? tangent_len / chord_len : 0.0;
      V3 carried = normalized_or(project_to_plane(v3(&flow[3 * size_t(parent)]), n), V3{});
      V3 step = normalized_or(project_to_plane(ctx.position(w) - ctx.position(parent), n), V3{});
      if (norm(carried) == 0) carried = step;
      V3 chord_dir = normalized_or(tangent, carried);
      store(&flow[3 * size_t(w)], normalized_or(chord_dir * trust + carried * (1 - trust), step));
    });
    parallel_vertices(nv, [&](int32_t v) {
      if (fixed[v] || singular_length[v] < 0) return;
      V3 s = v3(&flow[3 * size_t(v)]) * double(sign[v]);
      if (anchor_length[v] < 0) {
        store(&out[3 * size_t(v)], normalized_or_else(s, [&] { return ctx.axis_direction(v); }));
        return;
      }
      // Inverse path-length weights; the tiny epsilon only avoids 1/0 on root vertices.
      double wa = 1.0 / (anchor_length[v] + 1e-20), ws = 1.0 / (singular_length[v] + 1e-20);
      V3 a = v3(&out[3 * size_t(v)]);
      store(&out[3 * size_t(v)], normalized_or(a * wa + s * ws, a));
    });
  } else {
    // Unreached vertices (components without anchors) fall back to the projected axis.
    parallel_vertices(nv, [&](int32_t v) {
      if (anchor_length[v] < 0) store(&out[3 * size_t(v)], ctx.axis_direction(v));
    });
  }
  // Components reached by nothing at all.
  // (handled above: anchor_length < 0 and singular_length < 0 keep the zero vector until here)
  parallel_vertices(nv, [&](int32_t v) {
    float* o = &out[3 * size_t(v)];
    if (o[0] == 0.f && o[1] == 0.f && o[2] == 0.f) store(o, ctx.axis_direction(v));
  });

  throw_if_cancelled(p.cancel);
  // --- Jacobi smoothing, fixed vectors held; order-independent so thread count cannot matter
  std::vector<float> next(out.size());
  for (int it = 0; it < p.smoothing_iterations; ++it) {
    throw_if_cancelled(p.cancel);
    parallel_vertices(nv, [&](int32_t v) {
      const float* cur = &out[3 * size_t(v)];
      if (fixed[v] || m.degree(v) == 0) {
        std::copy(cur, cur + 3, &next[3 * size_t(v)]);
        return;
      }
      V3 sum = v3(cur);
      for (int32_t k = m.neighbour_start[v]; k < m.neighbour_start[v + 1]; ++k)
        sum = sum + v3(&out[3 * size_t(m.neighbours[k])]);
      V3 n = ctx.normal(v);
      V3 t = project_to_plane(sum, n);
      store(&next[3 * size_t(v)], normalized_or_else(t, [&] {
              return normalized_or_else(project_to_plane(v3(cur), n), [&] { return ctx.axis_direction(v); });
            }, 1e-6));
    });
    out.swap(next);
  }
  throw_if_cancelled(p.cancel);
  return out;
}

}  // namespace texsynth
