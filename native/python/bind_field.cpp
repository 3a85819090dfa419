// SPDX-License-Identifier: GPL-3.0-or-later
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include "field_args.hpp"

namespace py = pybind11;
using namespace texsynth_py;

void bind_field(py::module_& m) {
  m.def(
      "compute_field",
      [](py::object positions, py::object corner_verts, py::object poly_starts, py::object poly_sizes,
         const std::string& orientation, py::object axis, py::object direction, py::object anchor_vertices,
         py::object anchor_directions, py::object sources, py::object sinks, py::object normals) {
        const OrientedMeshArgs args = oriented_mesh_args(positions, corner_verts, poly_starts, poly_sizes, normals,
                                                         orientation, axis, direction, anchor_vertices,
                                                         anchor_directions, sources, sinks);
        std::vector<float> out;
        {
          py::gil_scoped_release release;
          out = std::move(args.build().up);
        }
        return to_numpy(std::move(out), {py::ssize_t(args.arrays.input.num_vertices), 3});
      },
      py::arg("positions"), py::arg("corner_verts"), py::arg("poly_starts"), py::arg("poly_sizes"), py::kw_only(),
      py::arg("orientation") = "axis", py::arg("axis") = py::make_tuple(0.0, 0.0, 1.0), py::arg("direction") = py::none(),
      py::arg("anchor_vertices") = py::none(), py::arg("anchor_directions") = py::none(), py::arg("sources") = py::none(),
      py::arg("sinks") = py::none(), py::arg("normals") = py::none(),
      "Per-vertex orientation field ('up' in texture space) as an (N, 3) float32 array of unit tangent vectors.\n"
      "orientation: 'axis' (axis projected on tangent planes), 'anchors' (anchor_vertices + anchor_directions "
      "and/or sources/sinks, propagated and smoothed) or 'field' (caller's direction (N, 3); zero or "
      "normal-parallel rows are filled in). Components with nothing to follow use the projected axis.");
}
