// SPDX-License-Identifier: GPL-3.0-or-later
// Texture particles, Blender output: decal_mesh() (particles/decals.hpp) and the analysis cache
// (particles/analysis_cache.hpp), returning the ParticleAnalysis type bound in bind_particles.cpp.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "array_args.hpp"
#include "call_helpers.hpp"
#include "cancel_arg.hpp"
#include "surface_args.hpp"
#include "texsynth/particles/analysis_cache.hpp"
#include "texsynth/particles/decals.hpp"

namespace py = pybind11;
using namespace texsynth_py;

namespace {

std::string path_arg(py::handle path) { return py::module_::import("os").attr("fspath")(path).cast<std::string>(); }

py::dict decal_stats(const texsynth::DecalStats& s) {
  return stats_dict("particles", s.particles, "empty", s.empty, "capped", s.capped, "curved", s.curved,
                    "faces_visited", s.faces_visited, "faces_folded", s.faces_folded, "overlapping", s.overlapping,
                    "stacked", s.stacked, "unstacked", s.unstacked, "max_level", s.max_level, "min_coverage", s.min_coverage,
                    "mean_coverage", s.mean_coverage, "seconds", s.seconds);
}

}  // namespace

void bind_particles_decals(py::module_& m) {
  m.def(
      "decal_mesh",
      [](const texsynth::SurfaceWalkMesh& mesh, py::object triangles, py::object barycentrics, py::object axes,
         py::object rects, py::object uv_rects, double offset, double stack_step, int32_t max_level,
         double max_normal_angle, py::object cancel) {
        const std::vector<texsynth::SurfacePoint> anchors =
            surface_points(triangles, barycentrics, "triangles", "barycentrics", -1);
        const py::ssize_t n = py::ssize_t(anchors.size());
        DoubleArray ax = double_array(axes, "axes"), r = double_array(rects, "rects"), uv = double_array(uv_rects, "uv_rects");
        require_shape(ax, {n, 3}, "axes");
        require_shape(r, {n, 4}, "rects");
        require_shape(uv, {n, 4}, "uv_rects");
        std::vector<texsynth::DecalParticle> ps(anchors.size());
        for (size_t i = 0; i < ps.size(); ++i) {
          ps[i].anchor = anchors[i];
          ps[i].axis = {ax.data()[3 * i], ax.data()[3 * i + 1], ax.data()[3 * i + 2]};
          for (int k = 0; k < 4; ++k) ps[i].rect[k] = r.data()[4 * i + k], ps[i].uv_rect[k] = uv.data()[4 * i + k];
        }
        texsynth::DecalOptions o;
        o.offset = offset;
        o.stack_step = stack_step;
        o.max_level = max_level;
        o.max_normal_angle = max_normal_angle;
        texsynth::DecalMesh d = cancellable(cancel, [&](const CallControl& control) {
          o.cancel = control.cancel;
          return texsynth::build_decal_mesh(mesh, ps.data(), int64_t(ps.size()), o);
        }, false);
        const py::ssize_t P = py::ssize_t(d.positions.size() / 3), F = py::ssize_t(d.loop_starts.size()),
                         C = py::ssize_t(d.corner_verts.size());
        py::dict out;
        out["positions"] = to_numpy(std::move(d.positions), {P, 3});
        out["loop_starts"] = to_numpy(std::move(d.loop_starts), {F});
        out["loop_totals"] = to_numpy(std::move(d.loop_totals), {F});
        out["corner_verts"] = to_numpy(std::move(d.corner_verts), {C});
        out["corner_uvs"] = to_numpy(std::move(d.corner_uvs), {C, 2});
        out["face_particle"] = to_numpy(std::move(d.face_particle), {F});
        out["source_triangle"] = to_numpy(std::move(d.face_triangle), {F});
        out["source_barycentric"] = to_numpy(std::move(d.corner_barycentric), {C, 2});
        out["curved"] = to_numpy(std::move(d.curved), {n}).attr("astype")("bool");
        out["level"] = to_numpy(std::move(d.level), {n});
        out["stats"] = decal_stats(d.stats);
        return out;
      },
      py::arg("walk_mesh"), py::arg("triangles"), py::arg("barycentrics"), py::arg("axes"), py::arg("rects"),
      py::arg("uv_rects"), py::kw_only(), py::arg("offset"), py::arg("stack_step") = 0.0,
      py::arg("max_level") = texsynth::kMaxDecalStackLevel,      py::arg("max_normal_angle") = 75.0, py::arg("cancel") = py::none(),
      "Decal polygons of n particles on walk_mesh (a SurfaceWalkMesh): anchors triangles (n,) / barycentrics (n, 2), "
      "axes (n, 3) world u directions (projected into the tangent plane; v = normal x u), rects (n, 4) (u0, v0, u1, v1) "
      "world units around the anchor (containing it), uv_rects (n, 4) (s0, t0, s1, t1) atlas cells. The target faces "
      "under each rectangle (flood fill while the face normal is within max_normal_angle degrees of the anchor's), "
      "clipped to it, on the surface, moved by offset along the smooth normal; vertices shared within a particle. "
      "stack_step > 0: decals whose rectangles overlap get different levels (level (n,) int32) and lie stack_step "
      "higher per level, at most max_level (no z-fighting; composite the higher level on top). "
      "Returns dict: positions (P, 3) float32, loop_starts / loop_totals (F,) int32, corner_verts (C,) int32, "
      "corner_uvs (C, 2) float32, face_particle (F,) int32, source_triangle (F,) int32 (the target triangle each polygon "
      "lies in) and source_barycentric (C, 2) float32 (each corner's (b1, b2) on it, before the offset), curved (n,) bool (footprint radius x curvature > 0.5), "
      "stats. Same result at any thread count. ValueError on bad input.");

  m.def(
      "save_particle_analysis",
      [](const std::shared_ptr<texsynth::ParticleAnalysis>& analysis, py::object path, uint64_t key) {
        if (!analysis) throw std::invalid_argument("analysis must be a ParticleAnalysis");
        const std::string p = path_arg(path);
        without_gil([&] { texsynth::save_particle_analysis(*analysis, p, key); });
      },
      py::arg("analysis"), py::arg("path"), py::arg("key"),
      "Writes a ParticleAnalysis to path (atomically) under key (an unsigned 64-bit fingerprint of the sample and "
      "settings, the caller's choice).");

  m.def(
      "load_particle_analysis",
      [](py::object path, uint64_t key) -> py::object {
        const std::string p = path_arg(path);
        std::optional<texsynth::ParticleAnalysis> a = without_gil([&] { return texsynth::load_particle_analysis(p, key); });
        if (!a) return py::none();
        return py::cast(std::make_shared<texsynth::ParticleAnalysis>(std::move(*a)));
      },
      py::arg("path"), py::arg("key"),
      "The ParticleAnalysis saved at path under key, or None for a missing file, another key or an older format. "
      "texsynth_native.CacheError (a ValueError) for a corrupt or truncated file.");
}
