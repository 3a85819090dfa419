// SPDX-License-Identifier: GPL-3.0-or-later
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include "array_args.hpp"
#include "texsynth/mesh/mesh.hpp"

namespace py = pybind11;
using namespace texsynth_py;

void bind_mesh(py::module_& m) {
  m.def(
      "mesh_info",
      [](py::object positions, py::object corner_verts, py::object poly_starts, py::object poly_sizes) {
        MeshArrays arrays = mesh_arrays(positions, corner_verts, poly_starts, poly_sizes);
        texsynth::Mesh mesh;
        {
          py::gil_scoped_release release;
          mesh = texsynth::build_mesh(arrays.input);
        }
        py::dict d;
        d["vertices"] = mesh.num_vertices;
        d["corners"] = mesh.num_corners;
        d["faces"] = mesh.num_polys;
        d["edges"] = mesh.num_edges();
        d["components"] = mesh.num_components;
        d["max_face_size"] = mesh.max_poly_size();
        return d;
      },
      py::arg("positions"), py::arg("corner_verts"), py::arg("poly_starts"), py::arg("poly_sizes"),
      "Validates a Blender-layout mesh (ValueError naming the problem) and returns its counts: "
      "vertices, corners, faces, edges, components (connected, with at least one corner), max_face_size.");
}
