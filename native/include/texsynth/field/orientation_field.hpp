// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Per-vertex orientation field: the unit tangent vector that is "up" in texture space
// (Zelinka & Garland §3, Magda & Kriegman §3.2.1).
//
// Modes
//  - Axis:    the global axis projected onto each tangent plane. Where the axis is (nearly)
//             parallel to the normal, the fallback axis (X, or Y when the axis is mostly X) is used.
//  - Anchors: sparse anchors (vertex + vector) and/or sources and sinks. Anchors are transported by
//             a multi-source breadth-first walk over edges (each vertex takes its BFS parent's
//             vector projected onto its own tangent plane). Sources/sinks are singularities: a second
//             walk gives vectors pointing away from the nearest source / toward the nearest sink,
//             along the BFS paths. Both fields are blended with weights 1/(path length), then
//             smoothed by Jacobi iterations with the anchors held fixed.
//  - Field:   a per-vertex field from the caller (e.g. painted). Vectors are projected and
//             normalised; zero or normal-parallel vectors are "unset" and filled as in Anchors mode
//             (set vectors act as fixed anchors; extra anchors/sources/sinks may be combined).
// Singularities: a source/sink vertex itself has no defined direction; it keeps the average of
// its neighbours after smoothing, or the projected global axis when that average cancels out.
// Components with no anchor, set vector, source or sink get the projected global axis.
#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

#include "texsynth/mesh/mesh.hpp"

namespace texsynth {

enum class OrientationMode { Axis, Anchors, Field };

struct FieldParams {
  OrientationMode mode = OrientationMode::Axis;
  Vec3f axis{0.f, 0.f, 1.f};
  const float* direction = nullptr;          // Field mode: num_vertices*3 (borrowed)
  std::vector<int32_t> anchor_vertices;
  std::vector<Vec3f> anchor_directions;      // same length as anchor_vertices
  std::vector<int32_t> sources;
  std::vector<int32_t> sinks;
  int smoothing_iterations = 6;
  const std::atomic<bool>* cancel = nullptr;  // raised by another thread: throws texsynth::Cancelled
};

// Parses "axis" | "anchors" | "field"; throws std::invalid_argument otherwise.
OrientationMode parse_orientation_mode(const std::string& name);

// Returns num_vertices*3 floats, each a unit vector in its vertex's tangent plane.
// Deterministic and independent of the thread count. Throws std::invalid_argument on bad params
// (out-of-range vertex ids, non-finite vectors, anchors parallel to their normal, zero axis,
// missing direction in Field mode, Anchors mode with no anchor/source/sink).
std::vector<float> compute_orientation_field(const Mesh& mesh, const FieldParams& params);

}  // namespace texsynth
