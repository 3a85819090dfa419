// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Orientation keyword arguments, and the mesh + normals + orientation arguments that compute_field
// and both synthesizers parse and build the same way.
#include <utility>

#include "array_args.hpp"
#include "texsynth/field/orientation_field.hpp"
#include "texsynth/mesh/mesh.hpp"

namespace texsynth_py {

struct FieldArgs {
  FloatArray direction;  // keeps the caller's direction array alive
  texsynth::FieldParams params;
};

inline FieldArgs field_args(int32_t num_vertices, const std::string& orientation, py::handle axis, py::handle direction,
                            py::handle anchor_vertices, py::handle anchor_directions, py::handle sources,
                            py::handle sinks) {
  FieldArgs f;
  f.params.mode = texsynth::parse_orientation_mode(orientation);
  f.params.axis = vec3(axis, "axis");
  f.direction = optional_vectors(direction, num_vertices, "direction");
  if (!direction.is_none()) f.params.direction = f.direction.data();
  if (f.params.mode == texsynth::OrientationMode::Field && direction.is_none())
    throw std::invalid_argument("orientation='field' needs direction=(N, 3) array");
  f.params.anchor_vertices = optional_indices(anchor_vertices, "anchor_vertices");
  if (!anchor_directions.is_none()) {
    FloatArray a = float_array(anchor_directions, "anchor_directions");
    require_shape(a, {py::ssize_t(f.params.anchor_vertices.size()), 3}, "anchor_directions");
    for (py::ssize_t i = 0; i < a.shape(0); ++i)
      f.params.anchor_directions.push_back({a.data()[3 * i], a.data()[3 * i + 1], a.data()[3 * i + 2]});
  } else if (!f.params.anchor_vertices.empty()) {
    throw std::invalid_argument("anchor_vertices given without anchor_directions");
  }
  f.params.sources = optional_indices(sources, "sources");
  f.params.sinks = optional_indices(sinks, "sinks");
  return f;
}

struct OrientedMeshArgs {
  MeshArrays arrays;
  FloatArray normals;  // keeps the caller's normals alive
  bool has_normals = false;
  FieldArgs field;  // field.params.cancel also stops the mesh build

  struct Built {
    texsynth::Mesh mesh;  // borrows arrays
    std::vector<float> up;
  };
  // The mesh tables and the per-vertex "up" field: heavy, call with the GIL released.
  Built build() const {
    Built built{texsynth::build_mesh(arrays.input, has_normals ? normals.data() : nullptr, field.params.cancel), {}};
    built.up = texsynth::compute_orientation_field(built.mesh, field.params);
    return built;
  }
};

inline OrientedMeshArgs oriented_mesh_args(py::handle positions, py::handle corner_verts, py::handle poly_starts,
                                           py::handle poly_sizes, py::handle normals, const std::string& orientation,
                                           py::handle axis, py::handle direction, py::handle anchor_vertices,
                                           py::handle anchor_directions, py::handle sources, py::handle sinks) {
  OrientedMeshArgs a{mesh_arrays(positions, corner_verts, poly_starts, poly_sizes), {}, !normals.is_none(), {}};
  const int32_t nv = a.arrays.input.num_vertices;
  a.normals = optional_vectors(normals, nv, "normals");
  a.field = field_args(nv, orientation, axis, direction, anchor_vertices, anchor_directions, sources, sinks);
  return a;
}

}  // namespace texsynth_py
