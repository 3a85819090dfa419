// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Per-polygon texture frame shared by the synthesizers: the polygon's corners as texel offsets
// from its corner 0, an exact similarity of the polygon's projection onto its plane.
// Rotation: the averaged vertex "up" vectors projected on the polygon plane (Magda & Kriegman
// §3.2.1); right = up × n (unmirrored, see jumpmap_synth.hpp); scale = scale × mean multiplier.
// Texel y points down, so an offset e maps to (e·right, -e·up) × scale.
#include <cmath>
#include <cstdint>
#include <sstream>
#include <stdexcept>
#include <string>

#include "texsynth/mesh/mesh.hpp"
#include "texsynth/mesh/vec_math.hpp"

namespace texsynth {

// Per-vertex inputs every synthesizer takes: the orientation field (N×3, finite) and the
// optional scale multiplier (N, finite and > 0).
inline void validate_vertex_inputs(const Mesh& m, const float* orientation, const float* scale_multiplier) {
  if (m.num_vertices > 0 && !orientation) throw std::invalid_argument("orientation field is missing");
  for (int64_t i = 0; i < int64_t(m.num_vertices) * 3; ++i)
    if (!std::isfinite(orientation[i]))
      throw std::invalid_argument("orientation of vertex " + std::to_string(i / 3) + " is NaN or infinite");
  if (scale_multiplier)
    for (int32_t v = 0; v < m.num_vertices; ++v)
      if (!std::isfinite(scale_multiplier[v]) || scale_multiplier[v] <= 0.f)
        throw std::invalid_argument("scale_multiplier of vertex " + std::to_string(v) + " must be finite and > 0");
}

// Refuses faces larger than the sample (counted by the synthesizer's face measuring pass) unless
// the caller allowed them, naming how far to lower the scale.
inline void check_oversized_faces(int64_t oversized_faces, double max_oversize_ratio, int32_t num_polys,
                                  int32_t sample_width, int32_t sample_height, double scale, bool allow_oversized) {
  if (oversized_faces == 0 || allow_oversized) return;
  std::ostringstream msg;
  msg << oversized_faces << " of " << num_polys << " faces are larger than the " << sample_width << "x"
      << sample_height << " sample at scale " << scale << " texels/unit (worst face " << max_oversize_ratio
      << "x the sample); lower the scale by at least that factor, subdivide those faces, or pass allow_oversized=True";
  throw std::invalid_argument(msg.str());
}

// A polygon's texture frame: texel offset of a point p from corner 0 is
// (dot(p - p0, right), -dot(p - p0, up)) × scale.
struct FaceFrame {
  V3 right, up;
  double scale = 0;
};

// up_of(v) returns vertex v's unit tangent "up" (V3).
template <class UpOf>
FaceFrame face_frame(const Mesh& m, int32_t poly, UpOf&& up_of, double scale, const float* multiplier) {
  const int32_t* cv = m.corner_verts + m.poly_starts[poly];
  const int32_t n = m.poly_sizes[poly];
  V3 up_sum;
  double mult = 0;
  for (int32_t i = 0; i < n; ++i) {
    up_sum = up_sum + up_of(cv[i]);
    mult += multiplier ? multiplier[cv[i]] : 1.0;
  }
  V3 nf = newell_vector(m.positions, cv, n);
  const double area2 = norm(nf);
  if (area2 > 1e-30 && std::isfinite(area2)) {
    nf = nf * (1.0 / area2);
  } else {  // zero-area polygon: its vertices' normals, which are always defined
    V3 normal_sum;
    for (int32_t i = 0; i < n; ++i) normal_sum = normal_sum + v3(&m.normals[3 * size_t(cv[i])]);
    nf = normalized_or(normal_sum, V3{0, 0, 1});
  }
  V3 up = project_to_plane(up_sum, nf);
  const double up_len = norm(up);
  if (up_len > 1e-12 && std::isfinite(up_len)) {
    up = up * (1.0 / up_len);
  } else {  // vertex directions cancel out (next to a singularity): corner 0's, else any
    up = normalized_or(project_to_plane(up_of(cv[0]), nf), any_perpendicular(nf));
  }
  FaceFrame f;
  f.up = up;
  f.right = cross(up, nf);
  f.scale = scale * mult / n;
  return f;
}

// The polygon's corners as texel offsets from its corner 0; xy receives poly_sizes[poly]*2 floats.
inline void face_texel_offsets(const Mesh& m, int32_t poly, const FaceFrame& f, float* xy) {
  const int32_t* cv = m.corner_verts + m.poly_starts[poly];
  const V3 origin = v3(m.positions + 3 * size_t(cv[0]));
  for (int32_t i = 0; i < m.poly_sizes[poly]; ++i) {
    const V3 e = v3(m.positions + 3 * size_t(cv[i])) - origin;
    xy[2 * i] = float(dot(e, f.right) * f.scale);
    xy[2 * i + 1] = float(-dot(e, f.up) * f.scale);
  }
}

template <class UpOf>
void face_texel_offsets(const Mesh& m, int32_t poly, UpOf&& up_of, double scale, const float* multiplier, float* xy) {
  face_texel_offsets(m, poly, face_frame(m, poly, up_of, scale, multiplier), xy);
}

// Edge vector e unfolded into frame f: the direction of its projection on the frame, its full 3D
// length (× scale). A function of the edge and the frame alone, whichever polygon asks.
inline void unfold_edge(const V3& e, const FaceFrame& f, float& dx, float& dy) {
  const double x = dot(e, f.right), y = dot(e, f.up);
  const double tangent = std::sqrt(x * x + y * y), length = norm(e);
  const double k = tangent > 1e-12 * length && tangent > 0 ? f.scale * length / tangent : 0.0;
  dx = float(x * k);
  dy = float(-y * k);
}

// Blend sets as vertex mappings (jumpmap_synth.hpp, texton_synth.hpp): texel offsets of polygon
// `poly`'s corners (at most 4) from its corner i in the mapping of corner i's vertex, whose frame is
// f. The two corners next to i are their edges unfolded, so both polygons on an edge give the
// mapping the same value there (C0 blending); a quad's opposite corner completes the parallelogram,
// plus the quad's own deviation from one in the same frame. Corner i gets (0, 0).
inline void vertex_mapping_offsets(const Mesh& m, int32_t poly, int32_t i, const FaceFrame& f, float* out) {
  const int32_t n = m.poly_sizes[poly];
  const int32_t* cv = m.corner_verts + m.poly_starts[poly];
  auto pos = [&](int32_t corner) { return v3(m.positions + 3 * size_t(cv[corner])); };
  const int32_t next = (i + 1) % n, prev = (i + n - 1) % n;
  out[2 * i] = out[2 * i + 1] = 0.f;
  for (int32_t j : {next, prev}) unfold_edge(pos(j) - pos(i), f, out[2 * j], out[2 * j + 1]);
  if (n == 4) {
    const int32_t o = (i + 2) % 4;
    const V3 d = pos(o) - pos(next) - pos(prev) + pos(i);
    out[2 * o] = out[2 * next] + out[2 * prev] + float(dot(d, f.right) * f.scale);
    out[2 * o + 1] = out[2 * next + 1] + out[2 * prev + 1] - float(dot(d, f.up) * f.scale);
  }
}

}  // namespace texsynth
