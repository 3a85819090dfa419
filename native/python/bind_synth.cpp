// SPDX-License-Identifier: GPL-3.0-or-later
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <chrono>

#include "call_helpers.hpp"
#include "cancel_arg.hpp"
#include "corner_map_arrays.hpp"
#include "field_args.hpp"
#include "texsynth/preprocess/preprocessed.hpp"
#include "texsynth/synth/jumpmap_synth.hpp"

namespace py = pybind11;
using namespace texsynth_py;

void bind_synth(py::module_& m) {
  bind_cancel_token(m);
  m.def(
      "synthesize_jumpmap",
      [](const texsynth::Preprocessed& pre, py::object positions, py::object corner_verts, py::object poly_starts,
         py::object poly_sizes, double scale, double jump_rate, uint64_t seed, bool blend, const std::string& orientation,
         py::object axis, py::object direction, py::object anchor_vertices, py::object anchor_directions,
         py::object sources, py::object sinks, py::object normals, py::object scale_multiplier, bool allow_oversized,
         py::object cancel, bool pack_sets, bool baseline_passes) {
        OrientedMeshArgs args = oriented_mesh_args(positions, corner_verts, poly_starts, poly_sizes, normals, orientation,
                                                   axis, direction, anchor_vertices, anchor_directions, sources, sinks);
        const texsynth::PolyMeshInput& input = args.arrays.input;
        FloatArray multiplier = optional_scale_multiplier(scale_multiplier, input.num_vertices);
        texsynth::JumpSynthParams params;
        params.scale = scale;
        params.jump_rate = jump_rate;
        params.seed = seed;
        params.blend = blend;
        params.allow_oversized = allow_oversized;
        params.baseline_passes = baseline_passes;
        params.scale_multiplier = scale_multiplier.is_none() ? nullptr : multiplier.data();
        params.cancel = args.field.params.cancel = cancel_flag(cancel);
        const CornerMapArrays maps(input.num_corners,
                                   texsynth::jumpmap_blend_sets(input.poly_sizes, input.num_polys, blend), pack_sets);
        texsynth::JumpSynthResult r;
        double mesh_seconds = 0;
        {
          py::gil_scoped_release release;
          const auto start = std::chrono::steady_clock::now();
          const OrientedMeshArgs::Built built = args.build();
          mesh_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
          r = texsynth::synthesize_jumpmap(pre, built.mesh, built.up.data(), params, maps.view);
        }
        const auto& s = r.stats;
        // seconds_mesh: build_mesh + orientation field, before `seconds`.
        py::dict stats = stats_dict(
            "faces", s.faces, "vertices", s.vertices, "corners", s.corners, "components", s.components, "jumps", s.jumps,
            "fallback_vertices", s.fallback_vertices, "fallback_faces", s.fallback_faces, "oversized_faces",
            s.oversized_faces, "max_oversize_ratio", s.max_oversize_ratio, "seconds", s.seconds, "seconds_mesh",
            mesh_seconds, "seconds_faces", s.seconds_faces, "seconds_walk", s.seconds_walk, "seconds_corners",
            s.seconds_corners);
        py::dict out;
        maps.put(out);
        out["stats"] = stats;
        return out;
      },
      py::arg("pre"), py::arg("positions"), py::arg("corner_verts"), py::arg("poly_starts"), py::arg("poly_sizes"),
      py::kw_only(), py::arg("scale"), py::arg("jump_rate") = 20.0, py::arg("seed") = 0, py::arg("blend") = true,
      py::arg("orientation") = "axis", py::arg("axis") = py::make_tuple(0.0, 0.0, 1.0), py::arg("direction") = py::none(),
      py::arg("anchor_vertices") = py::none(), py::arg("anchor_directions") = py::none(), py::arg("sources") = py::none(),
      py::arg("sinks") = py::none(), py::arg("normals") = py::none(), py::arg("scale_multiplier") = py::none(),
      py::arg("allow_oversized") = false, py::arg("cancel") = py::none(), py::arg("pack_sets") = false,
      py::arg("baseline_passes") = false,
      "Jump-map synthesis (Zelinka & Garland 2003) on a Blender-layout mesh. scale = texels per object unit.\n"
      "Returns dict: base_uv (L, 2), blend_uv (S, L, 2) (with pack_sets=True instead blend_set_pairs "
      "((S+1)/2, L, 4): (u0, v0, u1, v1), (u2, v2, u3, v3) per corner, 0 in an odd S's last slot), "
      "blend_weights (L, S) float32 (one-hot per corner), "
      "num_blend_sets S (3 all triangles, 4 otherwise, 1 when blend=False) and stats (faces, vertices, corners, "
      "components, jumps, fallback_vertices, fallback_faces, oversized_faces, max_oversize_ratio, seconds; "
      "seconds_mesh: mesh tables and orientation field before that; seconds_faces, seconds_walk, seconds_corners: "
      "phases within seconds). ValueError on bad input "
      "and, unless allow_oversized, when faces are larger than the sample at this scale. cancel: a CancelToken; "
      "token.cancel() from another thread makes the call raise Cancelled within a fraction of a second. "
      "baseline_passes: benchmark switch, the previous pass structure (same outputs, slower on incoherent meshes).");
}
