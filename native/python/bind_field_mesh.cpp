// SPDX-License-Identifier: GPL-3.0-or-later
// FieldMesh: a mesh validated and with adjacency built ONCE, for repeated field relaxations while
// the artist edits (compute_field rebuilds the adjacency on every call).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <memory>

#include "field_args.hpp"
#include "texsynth/mesh/mesh.hpp"

namespace py = pybind11;
using namespace texsynth_py;

namespace {

struct FieldMesh {
  // Owned copies: the Mesh borrows these.
  std::vector<float> positions;
  std::vector<int32_t> corner_verts, poly_starts, poly_sizes;
  texsynth::Mesh mesh;
};

}  // namespace

void bind_field_mesh(py::module_& m) {
  py::class_<FieldMesh>(m, "FieldMesh",
                        "A Blender-layout mesh validated once, with its adjacency and normals, for repeated "
                        "compute_field calls while a field is edited. Keeps its own copy: rebuild it when the "
                        "mesh changes.")
      .def(py::init([](py::object positions, py::object corner_verts, py::object poly_starts, py::object poly_sizes) {
             MeshArrays arrays = mesh_arrays(positions, corner_verts, poly_starts, poly_sizes);
             auto self = std::make_unique<FieldMesh>();
             const texsynth::PolyMeshInput& in = arrays.input;
             {
               py::gil_scoped_release release;
               self->positions.assign(in.positions, in.positions + 3 * size_t(in.num_vertices));
               self->corner_verts.assign(in.corner_verts, in.corner_verts + in.num_corners);
               self->poly_starts.assign(in.poly_starts, in.poly_starts + in.num_polys);
               self->poly_sizes.assign(in.poly_sizes, in.poly_sizes + in.num_polys);
               texsynth::PolyMeshInput own = in;
               own.positions = self->positions.data();
               own.corner_verts = self->corner_verts.data();
               own.poly_starts = self->poly_starts.data();
               own.poly_sizes = self->poly_sizes.data();
               self->mesh = texsynth::build_mesh(own);
             }
             return self;
           }),
           py::arg("positions"), py::arg("corner_verts"), py::arg("poly_starts"), py::arg("poly_sizes"))
      .def_property_readonly("num_vertices", [](const FieldMesh& self) { return self.mesh.num_vertices; })
      .def_property_readonly("normals",
                             [](const FieldMesh& self) {
                               auto copy = self.mesh.normals;
                               return to_numpy(std::move(copy), {py::ssize_t(self.mesh.num_vertices), 3});
                             },
                             "(N, 3) float32 unit vertex normals (those the field and synthesis use).")
      .def(
          "compute_field",
          [](const FieldMesh& self, const std::string& orientation, py::object axis, py::object direction,
             py::object anchor_vertices, py::object anchor_directions, py::object sources, py::object sinks) {
            FieldArgs field = field_args(self.mesh.num_vertices, orientation, axis, direction, anchor_vertices,
                                         anchor_directions, sources, sinks);
            std::vector<float> out;
            {
              py::gil_scoped_release release;
              out = texsynth::compute_orientation_field(self.mesh, field.params);
            }
            return to_numpy(std::move(out), {py::ssize_t(self.mesh.num_vertices), 3});
          },
          py::kw_only(), py::arg("orientation") = "axis", py::arg("axis") = py::make_tuple(0.0, 0.0, 1.0),
          py::arg("direction") = py::none(), py::arg("anchor_vertices") = py::none(),
          py::arg("anchor_directions") = py::none(), py::arg("sources") = py::none(), py::arg("sinks") = py::none(),
          "Same as texsynth_native.compute_field on this mesh (same keywords and result), without rebuilding it.");
}
