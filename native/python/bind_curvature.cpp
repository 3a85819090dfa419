// SPDX-License-Identifier: GPL-3.0-or-later
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include "array_args.hpp"
#include "texsynth/field/curvature.hpp"
#include "texsynth/mesh/mesh.hpp"

namespace py = pybind11;
using namespace texsynth_py;

void bind_curvature(py::module_& m) {
  m.def(
      "principal_curvature_directions",
      [](py::object positions, py::object corner_verts, py::object poly_starts, py::object poly_sizes,
         int smoothing_rings, double anisotropy_threshold) {
        MeshArrays arrays = mesh_arrays(positions, corner_verts, poly_starts, poly_sizes);
        texsynth::CurvatureParams params;
        params.smoothing_rings = smoothing_rings;
        params.anisotropy_threshold = anisotropy_threshold;
        texsynth::CurvatureResult r;
        {
          py::gil_scoped_release release;
          texsynth::Mesh mesh = texsynth::build_mesh(arrays.input);
          r = texsynth::principal_curvature_directions(mesh, params);
        }
        const py::ssize_t n = arrays.input.num_vertices;
        return py::make_tuple(to_numpy(std::move(r.min_direction), {n, 3}), to_numpy(std::move(r.curvatures), {n, 2}));
      },
      py::arg("positions"), py::arg("corner_verts"), py::arg("poly_starts"), py::arg("poly_sizes"), py::kw_only(),
      py::arg("smoothing_rings") = 2, py::arg("anisotropy_threshold") = 0.2,
      "(directions (N, 3), curvatures (N, 2)) float32: per vertex the principal direction of smaller |curvature| "
      "(sign-consistent; zero where flat or umbilic) and (k_flat, k_steep). Positive curvature = convex.");

  m.def(
      "vertex_normals",
      [](py::object positions, py::object corner_verts, py::object poly_starts, py::object poly_sizes) {
        MeshArrays arrays = mesh_arrays(positions, corner_verts, poly_starts, poly_sizes);
        texsynth::UninitializedVector<float> normals;
        {
          py::gil_scoped_release release;
          normals = std::move(texsynth::build_mesh(arrays.input).normals);
        }
        return to_numpy(std::move(normals), {py::ssize_t(arrays.input.num_vertices), 3});
      },
      py::arg("positions"), py::arg("corner_verts"), py::arg("poly_starts"), py::arg("poly_sizes"),
      "(N, 3) float32 unit vertex normals, exactly those the field and synthesis use (area-weighted; "
      "isolated vertices and zero-area neighbourhoods get a fallback).");
}
