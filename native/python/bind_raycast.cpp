// SPDX-License-Identifier: GPL-3.0-or-later
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cmath>
#include <limits>

#include "array_args.hpp"
#include "texsynth/raycast/raycaster.hpp"

namespace py = pybind11;
using namespace texsynth_py;

void bind_raycast(py::module_& m) {
  py::class_<texsynth::RayCaster>(m, "RayCaster",
                                  "Embree BVH over a Blender-layout polygon mesh (fan-triangulated), built once. "
                                  "Keeps its own copy of the mesh: rebuild it when the mesh changes.")
      .def(py::init([](py::object positions, py::object corner_verts, py::object poly_starts, py::object poly_sizes) {
             MeshArrays arrays = mesh_arrays(positions, corner_verts, poly_starts, poly_sizes);
             py::gil_scoped_release release;
             return new texsynth::RayCaster(arrays.input);
           }),
           py::arg("positions"), py::arg("corner_verts"), py::arg("poly_starts"), py::arg("poly_sizes"))
      .def_property_readonly("num_vertices", &texsynth::RayCaster::num_vertices)
      .def_property_readonly("num_polys", &texsynth::RayCaster::num_polys)
      .def_property_readonly("num_triangles", &texsynth::RayCaster::num_triangles)
      .def(
          "cast",
          [](const texsynth::RayCaster& self, py::object origins, py::object directions, double t_near, double t_far) {
            FloatArray o = float_array(origins, "origins"), d = float_array(directions, "directions");
            require_shape(o, {-1, 3}, "origins");
            require_shape(d, {o.shape(0), 3}, "directions");
            if (!(t_near >= 0) || std::isnan(t_far) || t_far < t_near)
              throw std::invalid_argument("need 0 <= t_near <= t_far");
            const py::ssize_t n = o.shape(0);
            std::vector<texsynth::RayHit> hits;
            {
              py::gil_scoped_release release;
              hits = self.cast(o.data(), d.data(), n, float(t_near),
                               float(std::min(t_far, double(std::numeric_limits<float>::max()))));
            }
            std::vector<int32_t> face(n), vertices(3 * size_t(n));
            std::vector<float> bary(3 * size_t(n)), distance(n);
            for (py::ssize_t i = 0; i < n; ++i) {
              face[i] = hits[i].face;
              distance[i] = hits[i].face < 0 ? std::numeric_limits<float>::infinity() : hits[i].distance;
              for (int k = 0; k < 3; ++k) vertices[3 * i + k] = hits[i].vertices[k], bary[3 * i + k] = hits[i].barycentrics[k];
            }
            py::dict out;
            out["face"] = to_numpy(std::move(face), {n});
            out["vertices"] = to_numpy(std::move(vertices), {n, 3});
            out["barycentrics"] = to_numpy(std::move(bary), {n, 3});
            out["distance"] = to_numpy(std::move(distance), {n});
            return out;
          },
          py::arg("origins"), py::arg("directions"), py::kw_only(), py::arg("t_near") = 0.0,
          py::arg("t_far") = std::numeric_limits<double>::infinity(),
          "Nearest hits of rays origins (n, 3) + t * directions (n, 3). Returns dict: face (n,) int32 polygon "
          "index (-1 = miss), vertices (n, 3) int32 of the hit fan triangle, barycentrics (n, 3) float32 of those "
          "vertices, distance (n,) float32 ray parameter t (inf on a miss).")
      .def(
          "vertices_within",
          [](const texsynth::RayCaster& self, py::object point, double radius) {
            texsynth::Vec3f p = vec3(point, "point");
            if (!std::isfinite(radius) || radius < 0 || radius > std::numeric_limits<float>::max())
              throw std::invalid_argument("radius must be a finite number >= 0");
            std::vector<int32_t> ids;
            std::vector<float> distances;
            {
              py::gil_scoped_release release;
              self.vertices_within(p.data(), float(radius), ids, distances);
            }
            const py::ssize_t n = py::ssize_t(ids.size());
            return py::make_tuple(to_numpy(std::move(ids), {n}), to_numpy(std::move(distances), {n}));
          },
          py::arg("point"), py::arg("radius"),
          "(ids int32, distances float32): the vertices within radius of point, ascending id.");
}
