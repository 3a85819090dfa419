// SPDX-License-Identifier: GPL-3.0-or-later
// Vector-field patches (Chen, Liu & Dong): the traced direction field and its grid patches.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <memory>
#include <vector>

#include "array_args.hpp"
#include "cancel_arg.hpp"
#include "texsynth/patches/grid_patch.hpp"

namespace py = pybind11;
using namespace texsynth_py;

void bind_patches(py::module_& m) {
  py::class_<texsynth::PatchField, std::shared_ptr<texsynth::PatchField>>(
      m, "PatchField",
      "A triangle mesh and its direction field prepared for tracing grid patches (patch_field()). Immutable; "
      "trace_grid_patches() may be called any number of times.")
      .def_property_readonly("num_vertices", [](const texsynth::PatchField& f) { return f.positions.size() / 3; })
      .def_property_readonly("num_triangles", [](const texsynth::PatchField& f) { return f.triangles.size() / 3; })
      .def_property_readonly("spacing", [](const texsynth::PatchField& f) { return f.spacing; })
      .def_property_readonly("unset_vertices", [](const texsynth::PatchField& f) { return f.unset_vertices; })
      .def_property_readonly("scale", [](const texsynth::PatchField& f) {
        return to_numpy(std::vector<float>(f.scale), {py::ssize_t(f.scale.size())});
      });

  m.def(
      "patch_field",
      [](py::object positions, py::object triangles, py::object directions, double spacing, py::object density,
         bool magnitude_scale, int32_t max_crossings, double singular_threshold, py::object cancel) {
        FloatArray pos = float_array(positions, "positions");
        IntArray tris = int_array(triangles, "triangles");
        FloatArray dirs = float_array(directions, "directions");
        require_shape(pos, {-1, 3}, "positions");
        require_shape(tris, {-1, 3}, "triangles");
        require_shape(dirs, {pos.shape(0), 3}, "directions");
        FloatArray dens;
        if (!density.is_none()) {
          dens = float_array(density, "density");
          require_shape(dens, {pos.shape(0)}, "density");
        }
        texsynth::PatchFieldInput in;
        in.mesh.positions = pos.data();
        in.mesh.num_vertices = checked_count(pos.shape(0), "positions");
        in.mesh.triangles = tris.data();
        in.mesh.num_triangles = checked_count(tris.shape(0), "triangles");
        in.directions = dirs.data();
        in.density = density.is_none() ? nullptr : dens.data();
        in.magnitude_scale = magnitude_scale;
        texsynth::PatchFieldParams params;
        params.spacing = spacing;
        params.max_crossings = max_crossings;
        params.singular_threshold = singular_threshold;
        params.cancel = cancel_flag(cancel);
        auto field = std::make_shared<texsynth::PatchField>();
        {
          py::gil_scoped_release release;
          *field = texsynth::build_patch_field(in, params);
        }
        return field;
      },
      py::arg("positions"), py::arg("triangles"), py::arg("directions"), py::kw_only(), py::arg("spacing"),
      py::arg("density") = py::none(), py::arg("magnitude_scale") = false, py::arg("max_crossings") = 64,
      py::arg("singular_threshold") = 1e-3, py::arg("cancel") = py::none(),
      "Prepares a direction field for tracing grid patches: positions (V, 3), triangles (T, 3) (Blender loop "
      "triangles), directions (V, 3) (the texture's up; zero or NaN rows are unset and take the nearest set "
      "vertex's), spacing (world distance of one grid step at scale 1), density (V,) optional scale field "
      "(2 = features half as large), magnitude_scale (the directions' lengths set the step instead). "
      "ValueError on bad input; cancel: a CancelToken.");

  m.def(
      "trace_grid_patches",
      [](const texsynth::PatchField& field, py::object centre_triangles, py::object centre_barycentrics, int32_t size,
         py::object cancel) {
        IntArray ct = int_array(centre_triangles, "centre_triangles");
        FloatArray cb = float_array(centre_barycentrics, "centre_barycentrics");
        require_shape(ct, {-1}, "centre_triangles");
        require_shape(cb, {ct.shape(0), 2}, "centre_barycentrics");
        const int32_t count = checked_count(ct.shape(0), "centre_triangles");
        std::vector<texsynth::FacePoint> centres(static_cast<size_t>(count));
        for (int32_t i = 0; i < count; ++i) centres[i] = {ct.data()[i], cb.data()[2 * i], cb.data()[2 * i + 1]};
        texsynth::GridPatches g;
        {
          py::gil_scoped_release release;
          g = texsynth::trace_grid_patches(field, centres.data(), count, size, cancel_flag(cancel));
        }
        const py::ssize_t n = count, s = size;
        std::vector<int32_t> tri(g.points.size());
        std::vector<float> bary(2 * g.points.size());
        for (size_t k = 0; k < g.points.size(); ++k) {
          tri[k] = g.points[k].triangle;
          bary[2 * k] = g.points[k].b1, bary[2 * k + 1] = g.points[k].b2;
        }
        py::dict out;
        out["triangle"] = to_numpy(std::move(tri), {n, s, s});
        out["barycentrics"] = to_numpy(std::move(bary), {n, s, s, 2});
        out["positions"] = to_numpy(std::move(g.positions), {n, s, s, 3});
        out["cell_valid"] = to_numpy(std::move(g.cell_valid), {n, s - 1, s - 1});
        out["invalid_points"] = g.invalid_points;
        out["invalid_cells"] = g.invalid_cells;
        return out;
      },
      py::arg("field"), py::arg("centre_triangles"), py::arg("centre_barycentrics"), py::kw_only(),
      py::arg("size") = 32, py::arg("cancel") = py::none(),
      "Grid patches of size x size points traced along the field from N centres (centre_triangles (N,), "
      "centre_barycentrics (N, 2)). Point [p, j, i]: i along sample +x (up x normal), j along +y (up); the centre "
      "is [size//2, size//2]. Returns dict: triangle (N, size, size) int32 (-1: the trace stopped at a boundary, "
      "singularity or crossing cap), barycentrics (N, size, size, 2), positions (N, size, size, 3) (0 where "
      "invalid), cell_valid (N, size-1, size-1) uint8, invalid_points, invalid_cells.");
}
