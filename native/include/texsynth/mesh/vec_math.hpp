// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Minimal 3-vector helpers for the mesh/field/synth hot loops (plain structs: no Eigen
// temporaries, trivially inlined, identical results whatever the build's vectorisation).
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "texsynth/mesh/poly_mesh.hpp"

namespace texsynth {

struct V3 {
  double x = 0, y = 0, z = 0;
};
inline V3 v3(const float* p) { return {p[0], p[1], p[2]}; }
inline V3 v3(const Vec3f& p) { return {p[0], p[1], p[2]}; }
inline V3 operator+(V3 a, V3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline V3 operator-(V3 a, V3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline V3 operator*(V3 a, double s) { return {a.x * s, a.y * s, a.z * s}; }
inline double dot(V3 a, V3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline V3 cross(V3 a, V3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
inline double norm(V3 a) { return std::sqrt(dot(a, a)); }
// Component of `a` in the plane with unit normal `n`.
inline V3 project_to_plane(V3 a, V3 n) { return a - n * dot(a, n); }
// a / |a|, or `fallback` when |a| is too small to define a direction.
inline V3 normalized_or(V3 a, V3 fallback, double min_len = 1e-12) {
  double len = norm(a);
  return len > min_len && std::isfinite(len) ? a * (1.0 / len) : fallback;
}
inline void store(float* out, V3 a) {
  out[0] = static_cast<float>(a.x);
  out[1] = static_cast<float>(a.y);
  out[2] = static_cast<float>(a.z);
}
// A unit vector perpendicular to unit `n`: the world axis least aligned with n, projected.
inline V3 any_perpendicular(V3 n) {
  V3 axis = std::fabs(n.x) <= std::fabs(n.y) && std::fabs(n.x) <= std::fabs(n.z) ? V3{1, 0, 0}
            : std::fabs(n.y) <= std::fabs(n.z)                                   ? V3{0, 1, 0}
                                                                                 : V3{0, 0, 1};
  return normalized_or(project_to_plane(axis, n), V3{1, 0, 0});
}

// Newell's vector of a polygon (corners cv[0..n) into positions): 2 × area × unit normal, exact
// for planar polygons and a robust average normal for non-planar ones.
inline V3 newell_vector(const float* positions, const int32_t* cv, int32_t n) {
  const V3 origin = v3(positions + 3 * size_t(cv[0]));
  V3 prev = v3(positions + 3 * size_t(cv[1])) - origin, sum;
  for (int32_t i = 2; i < n; ++i) {
    V3 cur = v3(positions + 3 * size_t(cv[i])) - origin;
    sum = sum + cross(prev, cur);
    prev = cur;
  }
  return sum;
}

}  // namespace texsynth
