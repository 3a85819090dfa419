// SPDX-License-Identifier: GPL-3.0-or-later
// Texture particles on the surface (§2.3): normal-section walks (the inverse of dist) and the
// pseudo-geodesic distance, batched over numpy arrays.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "array_args.hpp"
#include "call_helpers.hpp"
#include "cancel_arg.hpp"
#include "surface_args.hpp"
#include "texsynth/particles/surface_walk.hpp"

namespace py = pybind11;
using namespace texsynth_py;

namespace {

texsynth::SectionWalkOptions options(int32_t max_faces, double max_length_factor) {
  texsynth::SectionWalkOptions o;
  o.max_faces = max_faces;
  o.max_length_factor = max_length_factor;
  return o;
}

}  // namespace

void bind_particles_walk(py::module_& m) {
  py::class_<texsynth::SurfaceWalkMesh, std::shared_ptr<texsynth::SurfaceWalkMesh>>(
      m, "SurfaceWalkMesh",
      "A triangle mesh prepared for normal-section walks (surface_walk_mesh()). Immutable; reusable.")
      .def_property_readonly("num_vertices", [](const texsynth::SurfaceWalkMesh& s) { return s.positions.size() / 3; })
      .def_property_readonly("num_triangles", [](const texsynth::SurfaceWalkMesh& s) { return s.triangles.size() / 3; });

  m.attr("walk_statuses") = py::make_tuple("reached", "wall", "face_limit", "length_limit", "no_plane");
  m.attr("distance_kinds") = py::make_tuple("section", "reverse_section", "chord", "opposite_normals");

  m.def(
      "surface_walk_mesh",
      [](py::object positions, py::object triangles, py::object cancel) {
        FloatArray pos = float_array(positions, "positions");
        IntArray tris = int_array(triangles, "triangles");
        require_shape(pos, {-1, 3}, "positions");
        require_shape(tris, {-1, 3}, "triangles");
        texsynth::TriangleMeshInput in;
        in.positions = pos.data();
        in.num_vertices = checked_count(pos.shape(0), "positions");
        in.triangles = tris.data();
        in.num_triangles = checked_count(tris.shape(0), "triangles");
        auto out = std::make_shared<texsynth::SurfaceWalkMesh>();
        *out = cancellable(cancel, [&](const CallControl& control) {
          return texsynth::build_surface_walk_mesh(in, control.cancel);
        }, false);
        return out;
      },
      py::arg("positions"), py::arg("triangles"), py::kw_only(), py::arg("cancel") = py::none(),
      "Prepares positions (V, 3) and triangles (T, 3) (Blender loop triangles) for walks. ValueError on bad "
      "input.");

  m.def(
      "walk_normal_sections",
      [](const texsynth::SurfaceWalkMesh& mesh, py::object triangles, py::object barycentrics, py::object directions,
         py::object lengths, int32_t max_faces, py::object cancel) {
        std::vector<texsynth::SurfacePoint> starts = surface_points(triangles, barycentrics, "triangles", "barycentrics", -1);
        const py::ssize_t n = py::ssize_t(starts.size());
        DoubleArray dirs = double_array(directions, "directions");
        DoubleArray lens = double_array(lengths, "lengths");
        require_shape(dirs, {n, 3}, "directions");
        require_shape(lens, {n}, "lengths");
        std::vector<texsynth::SectionWalkRequest> req(starts.size());
        for (size_t i = 0; i < req.size(); ++i) {
          const double* d = dirs.data() + 3 * i;
          req[i] = {starts[i], {d[0], d[1], d[2]}, lens.data()[i]};
        }
        const std::vector<texsynth::SectionWalkResult> r = cancellable(cancel, [&](const CallControl& control) {
          return texsynth::walk_normal_sections(mesh.walk, mesh.input(), req.data(), int64_t(req.size()),
                                                options(max_faces, 3.0), control.cancel);
        }, false);
        std::vector<int32_t> tri(r.size()), faces(r.size());
        std::vector<double> bary(2 * r.size()), pos(3 * r.size()), dir(3 * r.size()), len(r.size());
        std::vector<uint8_t> status(r.size());
        for (size_t i = 0; i < r.size(); ++i) {
          tri[i] = r[i].end.triangle, bary[2 * i] = r[i].end.b1, bary[2 * i + 1] = r[i].end.b2;
          const texsynth::V3 p = r[i].position, d = r[i].direction;
          pos[3 * i] = p.x, pos[3 * i + 1] = p.y, pos[3 * i + 2] = p.z;
          dir[3 * i] = d.x, dir[3 * i + 1] = d.y, dir[3 * i + 2] = d.z;
          len[i] = r[i].length, faces[i] = r[i].faces, status[i] = uint8_t(r[i].status);
        }
        py::dict out;
        out["triangle"] = to_numpy(std::move(tri), {n});
        out["barycentrics"] = to_numpy(std::move(bary), {n, 2});
        out["positions"] = to_numpy(std::move(pos), {n, 3});
        out["directions"] = to_numpy(std::move(dir), {n, 3});
        out["length"] = to_numpy(std::move(len), {n});
        out["faces"] = to_numpy(std::move(faces), {n});
        out["status"] = to_numpy(std::move(status), {n});
        return out;
      },
      py::arg("mesh"), py::arg("triangles"), py::arg("barycentrics"), py::arg("directions"), py::arg("lengths"),
      py::kw_only(), py::arg("max_faces") = 10000, py::arg("cancel") = py::none(),
      "N walks along normal sections (the inverse of the pseudo-geodesic distance): from triangles (N,) / "
      "barycentrics (N, 2) (of corners 1 and 2), in directions (N, 3) (projected into the start face), for "
      "lengths (N,). Returns dict: triangle, barycentrics (N, 2) float64, positions (N, 3), directions (N, 3) "
      "(unit direction of travel at the end), length (arc walked), faces, status (N,) uint8 indexing "
      "walk_statuses (reached, wall, face_limit, no_plane). ValueError on bad input.");

  m.def(
      "pseudo_geodesic_distances",
      [](const texsynth::SurfaceWalkMesh& mesh, py::object triangles1, py::object barycentrics1, py::object triangles2,
         py::object barycentrics2, int32_t max_faces, double max_length_factor, py::object cancel) {
        std::vector<texsynth::SurfacePoint> a = surface_points(triangles1, barycentrics1, "triangles1", "barycentrics1", -1);
        std::vector<texsynth::SurfacePoint> b =
            surface_points(triangles2, barycentrics2, "triangles2", "barycentrics2", py::ssize_t(a.size()));
        const std::vector<texsynth::PseudoGeodesic> r = cancellable(cancel, [&](const CallControl& control) {
          return texsynth::pseudo_geodesic_distances(mesh.walk, mesh.input(), a.data(), b.data(), int64_t(a.size()),
                                                     options(max_faces, max_length_factor), control.cancel);
        }, false);
        std::vector<double> dist(r.size());
        std::vector<uint8_t> kind(r.size());
        for (size_t i = 0; i < r.size(); ++i) dist[i] = r[i].distance, kind[i] = uint8_t(r[i].kind);
        const py::ssize_t n = py::ssize_t(r.size());
        py::dict out;
        out["distance"] = to_numpy(std::move(dist), {n});
        out["kind"] = to_numpy(std::move(kind), {n});
        return out;
      },
      py::arg("mesh"), py::arg("triangles1"), py::arg("barycentrics1"), py::arg("triangles2"),
      py::arg("barycentrics2"), py::kw_only(), py::arg("max_faces") = 10000, py::arg("max_length_factor") = 3.0,
      py::arg("cancel") = py::none(),
      "Symmetric pseudo-geodesic distances (§2.3) between N point pairs: min(dist(P1, P2), dist(P2, P1)) along "
      "normal sections, the chord when neither section reaches, inf when the smooth normals face away (N1.N2 < 0: "
      "two sides of a thin part never conflict). Returns dict: distance (N,) float64, kind (N,) uint8 indexing "
      "distance_kinds. ValueError on bad input.");
}
