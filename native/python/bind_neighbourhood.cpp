// SPDX-License-Identifier: GPL-3.0-or-later
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <algorithm>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "array_args.hpp"
#include "call_helpers.hpp"
#include "cancel_arg.hpp"
#include "texsynth/neighbourhood/round_rings.hpp"

namespace py = pybind11;
using namespace texsynth_py;

namespace {

// A read-only numpy view into the RoundRings kept alive by `owner` (the ring table can be hundreds of
// MB: no copy, and no writes that would desynchronise the interleaved fields).
template <class T>
py::array view(const std::vector<py::ssize_t>& shape, const std::vector<py::ssize_t>& strides, const void* data,
               const py::capsule& owner) {
  py::array a(py::dtype::of<T>(), shape, strides, data, owner);
  a.attr("setflags")(py::arg("write") = false);
  return a;
}

}  // namespace

void bind_neighbourhood(py::module_& m) {
  m.def(
      "round_rings",
      [](py::object positions, py::object triangles, py::object point_triangles, py::object point_barycentrics,
         py::object point_radius, int rings, double facing_limit_degrees, int32_t max_steps, double max_megabytes,
         py::object cancel) {
        FloatArray pos = float_array(positions, "positions");
        IntArray tris = int_array(triangles, "triangles");
        IntArray pt = int_array(point_triangles, "point_triangles");
        FloatArray bary = float_array(point_barycentrics, "point_barycentrics");
        FloatArray radius = float_array(point_radius, "point_radius");
        require_shape(pos, {-1, 3}, "positions");
        require_shape(tris, {-1, 3}, "triangles");
        require_shape(pt, {-1}, "point_triangles");
        require_shape(bary, {pt.shape(0), 2}, "point_barycentrics");
        if (radius.ndim() == 0) {  // one radius for every point
          FloatArray full(std::vector<py::ssize_t>{pt.shape(0)});
          std::fill_n(full.mutable_data(), pt.shape(0), *radius.data());
          radius = full;
        }
        require_shape(radius, {pt.shape(0)}, "point_radius");
        texsynth::TriangleMeshInput mesh;
        mesh.positions = pos.data();
        mesh.num_vertices = checked_count(pos.shape(0), "positions");
        mesh.triangles = tris.data();
        mesh.num_triangles = checked_count(tris.shape(0), "triangles");
        texsynth::SurfacePoints pts;
        pts.triangle = pt.data();
        pts.barycentric = bary.data();
        pts.radius = radius.data();
        pts.num_points = checked_count(pt.shape(0), "point_triangles");
        texsynth::RoundRingsParams params;
        params.rings = rings;
        params.facing_limit_degrees = facing_limit_degrees;
        params.max_steps = max_steps;
        params.max_megabytes = max_megabytes;
        auto result = std::make_unique<texsynth::RoundRings>();
        *result = cancellable(cancel, [&](const CallControl& control) {
          params.cancel = control.cancel;
          return texsynth::build_round_rings(mesh, pts, params);
        }, false);
        const texsynth::RoundRings& rr = *result;
        const py::ssize_t n = rr.num_points, e = rr.entries_per_point, entry = sizeof(texsynth::RingPoint);
        const auto* base = reinterpret_cast<const char*>(rr.points.data());
        std::vector<int32_t> offsets;
        for (int ring = 1; ring <= rr.rings + 1; ++ring) offsets.push_back(texsynth::ring_offset(ring));
        std::vector<int64_t> per_ring(rr.invalid_per_ring.begin(), rr.invalid_per_ring.end());
        const int64_t result_bytes = texsynth::estimate_round_rings_memory(n, 0, 0, rr.rings).result_bytes;
        py::dict out;
        out["rings"] = rr.rings;
        out["ring_offsets"] = to_numpy(std::move(offsets), {py::ssize_t(rr.rings) + 1});
        out["invalid_count"] = rr.invalid_count;
        out["invalid_fraction"] = rr.invalid_fraction();
        out["invalid_per_ring"] = to_numpy(std::move(per_ring), {py::ssize_t(rr.rings)});
        out["bytes"] = result_bytes;
        py::capsule owner(result.release(), [](void* p) { delete static_cast<texsynth::RoundRings*>(p); });
        out["triangle"] = view<int32_t>({n, e}, {e * entry, entry}, base, owner);
        out["barycentrics"] =
            view<uint16_t>({n, e, 2}, {e * entry, entry, py::ssize_t(sizeof(uint16_t))}, base + sizeof(int32_t), owner);
        out["normal"] = view<float>({n, 3}, {3 * py::ssize_t(sizeof(float)), py::ssize_t(sizeof(float))},
                                    rr.normal.data(), owner);
        out["tangent"] = view<float>({n, 3}, {3 * py::ssize_t(sizeof(float)), py::ssize_t(sizeof(float))},
                                     rr.tangent.data(), owner);
        return out;
      },
      py::arg("positions"), py::arg("triangles"), py::arg("point_triangles"), py::arg("point_barycentrics"),
      py::arg("point_radius"), py::kw_only(), py::arg("rings") = 4, py::arg("facing_limit_degrees") = 75.0,
      py::arg("max_steps") = 4096, py::arg("max_megabytes") = texsynth::kDefaultRoundRingsMaxMegabytes,
      py::arg("cancel") = py::none(),
      "Direction-invariant round neighbourhoods (Chen & Dong 2008) of N surface points on a triangle mesh: "
      "positions (V, 3), triangles (T, 3) (Blender loop triangles), point_triangles (N,), point_barycentrics "
      "(N, 2) (b1, b2 of corners 1 and 2), point_radius (N,) or a scalar (r > 0). Ring m (1..rings) has 8m bins; "
      "bin a is where a straightest geodesic leaving at 2*pi*a/(8m) counter-clockwise from the point's tangent "
      "has travelled m*r. Returns dict (read-only views, no copies): triangle (N, E) int32 (-1 = not reached), "
      "barycentrics (N, E, 2) uint16 (b1, b2 = value/65535), ring_offsets (rings+1,) int32 (ring m is "
      "entries [offsets[m-1], offsets[m])), normal and tangent (N, 3) float32, rings, invalid_count, "
      "invalid_fraction, invalid_per_ring (rings,) int64, bytes. ValueError on bad input or above max_megabytes; "
      "cancel: a CancelToken.");

  m.def(
      "round_rings_memory",
      [](int64_t num_points, int64_t num_triangles, int64_t num_vertices, int rings) {
        if (num_points < 0 || num_triangles < 0 || num_vertices < 0 || rings < 1 || rings > texsynth::kMaxRings)
          throw std::invalid_argument("round_rings_memory: counts must be >= 0 and rings 1.." +
                                      std::to_string(texsynth::kMaxRings));
        const texsynth::RoundRingsMemory mem =
            texsynth::estimate_round_rings_memory(num_points, num_triangles, num_vertices, rings);
        return py::make_tuple(mem.result_bytes, mem.peak_bytes);
      },
      py::arg("num_points"), py::arg("num_triangles"), py::arg("num_vertices"), py::arg("rings") = 4,
      "(result_bytes, peak_bytes) that round_rings would need; it refuses when peak_bytes exceeds max_megabytes.");
}
