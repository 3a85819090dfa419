// SPDX-License-Identifier: GPL-3.0-or-later
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <chrono>
#include <cmath>

#include "call_helpers.hpp"
#include "cancel_arg.hpp"
#include "corner_map_arrays.hpp"
#include "field_args.hpp"
#include "texsynth/mesh/mesh.hpp"
#include "texsynth/mesh/mesh_edges.hpp"
#include "texsynth/preprocess/preprocessed.hpp"
#include "texsynth/preprocess/working_image.hpp"
#include "texsynth/synth/texton_synth.hpp"

namespace py = pybind11;
using namespace texsynth_py;

namespace {

// (H, W) or (H, W, C) float pixels; the array keeps them alive.
texsynth::SampleImage sample_image(const FloatArray& a) {
  if (a.ndim() != 2 && a.ndim() != 3)
    throw std::invalid_argument("sample_pixels must have shape (H, W) or (H, W, C), got " + std::to_string(a.ndim()) + " dims");
  texsynth::SampleImage s;
  s.pixels = a.data();
  s.height = checked_count(a.shape(0), "sample_pixels");
  s.width = checked_count(a.shape(1), "sample_pixels");
  s.channels = a.ndim() == 3 ? checked_count(a.shape(2), "sample_pixels") : 1;
  return s;
}

py::array_t<int32_t> edge_vertex_array(texsynth::UninitializedVector<int32_t>&& v) {
  const py::ssize_t E = py::ssize_t(v.size() / 2);
  return to_numpy(std::move(v), {E, 2});
}

}  // namespace

void bind_texton(py::module_& m) {
  m.def(
      "synthesize_texton",
      [](const texsynth::Preprocessed& pre, py::object sample_pixels, py::object positions, py::object corner_verts,
         py::object poly_starts, py::object poly_sizes, double scale, uint64_t seed, bool blend, int top_m,
         int max_vote_points, int max_votes, double tie_tolerance, const std::string& orientation, py::object axis, py::object direction,
         py::object anchor_vertices, py::object anchor_directions, py::object sources, py::object sinks,
         py::object normals, py::object scale_multiplier, py::object camera_position, py::object blend_threshold,
         double lambda, bool allow_oversized, py::object cancel, bool pack_sets, double coherence_threshold,
         int seeds_per_component, bool fallback_search) {
        OrientedMeshArgs args = oriented_mesh_args(positions, corner_verts, poly_starts, poly_sizes, normals, orientation,
                                                   axis, direction, anchor_vertices, anchor_directions, sources, sinks);
        FloatArray pixels = float_array(sample_pixels, "sample_pixels");
        texsynth::SampleImage sample = sample_image(pixels);
        // A sample analysed through a working size: E_t compares the analysis copy, so scale the given
        // full-resolution pixels down the same way (any other size is refused by synthesize_texton).
        const bool scale_down = pre.sample_width > 0 && (sample.width != pre.width || sample.height != pre.height) &&
                                sample.width == pre.sample_width && sample.height == pre.sample_height;
        std::vector<float> scaled;
        FloatArray multiplier = optional_scale_multiplier(scale_multiplier, args.arrays.input.num_vertices);
        texsynth::TextonSynthParams params;
        params.scale = scale;
        params.seed = seed;
        params.blend = blend;
        params.search.top_m = top_m;
        params.search.max_vote_points = max_vote_points;
        params.search.max_votes = max_votes;
        params.search.tie_tolerance = tie_tolerance;
        params.search.coherence_threshold = coherence_threshold;
        params.search.fallback_search = fallback_search;
        params.seeds_per_component = seeds_per_component;
        params.allow_oversized = allow_oversized;
        params.lambda = lambda;
        params.scale_multiplier = scale_multiplier.is_none() ? nullptr : multiplier.data();
        params.cancel = args.field.params.cancel = cancel_flag(cancel);
        if (!camera_position.is_none()) {
          const texsynth::Vec3f c = vec3(camera_position, "camera_position");
          params.has_camera = true;
          params.camera[0] = c[0], params.camera[1] = c[1], params.camera[2] = c[2];
        }
        if (!blend_threshold.is_none()) {
          params.blend_threshold = blend_threshold.cast<double>();
          if (std::isnan(params.blend_threshold)) throw std::invalid_argument("blend_threshold must not be NaN");
        }
        texsynth::TextonSynthResult r;
        const py::ssize_t L = args.arrays.input.num_corners;
        const CornerMapArrays maps(L, texsynth::texton_blend_sets(blend), pack_sets);
        py::array_t<bool> corner_blended({L});
        py::array_t<float> corner_error({L});
        bool* corner_blended_out = corner_blended.mutable_data();
        float* corner_error_out = corner_error.mutable_data();
        double mesh_seconds = 0;
        {
          py::gil_scoped_release release;
          if (scale_down) {
            scaled = texsynth::area_downscale(sample.pixels, sample.width, sample.height, sample.channels, pre.width,
                                              pre.height, params.cancel);
            sample.pixels = scaled.data();
            sample.width = pre.width;
            sample.height = pre.height;
          }
          const auto start = std::chrono::steady_clock::now();
          const OrientedMeshArgs::Built built = args.build();
          mesh_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
          r = texsynth::synthesize_texton(pre, built.mesh, built.up.data(), sample, params, maps.view);
          // Per corner: the edge from this corner to the next (what the add-on shows as attributes).
          tbb::parallel_for(tbb::blocked_range<py::ssize_t>(0, L, 65536), [&](const tbb::blocked_range<py::ssize_t>& range) {
            for (py::ssize_t c = range.begin(); c < range.end(); ++c) {
              const int32_t e = r.edges.corner_edge[c];
              corner_blended_out[c] = e >= 0 && r.edge_blended[e];
              corner_error_out[c] = e >= 0 ? r.edge_error[e] : 0.f;
            }
          });
        }
        const py::ssize_t E = r.edges.num_edges();
        const auto& s = r.stats;
        // seconds_mesh: build_mesh + orientation field, before `seconds`.
        py::dict stats = stats_dict(
            "faces", s.faces, "vertices", s.vertices, "corners", s.corners, "components", s.components,
            "searched_faces", s.searched_faces, "fallback_faces", s.fallback_faces, "oversized_faces", s.oversized_faces,
            "max_oversize_ratio", s.max_oversize_ratio, "coherent_faces", s.coherent_faces, "regions", s.regions,
            "border_faces", s.border_faces, "blended_edges", s.blended_edges, "clipped_blend_sets", s.clipped_blend_sets,
            "seconds", s.seconds, "seconds_mesh", mesh_seconds, "seconds_edges", s.seconds_edges, "seconds_faces",
            s.seconds_faces, "seconds_grow", s.seconds_grow, "seconds_error", s.seconds_error, "seconds_blend",
            s.seconds_blend);
        py::dict out;
        maps.put(out);
        out["stats"] = stats;
        out["edge_vertices"] = edge_vertex_array(std::move(r.edges.vertices));
        out["edge_error"] = to_numpy(std::move(r.edge_error), {E});
        out["edge_phi"] = to_numpy(std::move(r.edge_phi), {E});
        out["edge_blended"] = to_numpy(std::move(r.edge_blended), {E}).attr("astype")("bool");
        out["corner_edge_blended"] = corner_blended;
        out["corner_edge_error"] = corner_error;
        const py::ssize_t F = py::ssize_t(r.face_region.size());
        out["face_region"] = to_numpy(std::move(r.face_region), {F});
        return out;
      },
      py::arg("pre"), py::arg("sample_pixels"), py::arg("positions"), py::arg("corner_verts"), py::arg("poly_starts"),
      py::arg("poly_sizes"), py::kw_only(), py::arg("scale"), py::arg("seed") = 0, py::arg("blend") = true,
      py::arg("top_m") = 16, py::arg("max_vote_points") = 16, py::arg("max_votes") = 1024,
      py::arg("tie_tolerance") = 0.05,
      py::arg("orientation") = "axis", py::arg("axis") = py::make_tuple(0.0, 0.0, 1.0), py::arg("direction") = py::none(),
      py::arg("anchor_vertices") = py::none(), py::arg("anchor_directions") = py::none(), py::arg("sources") = py::none(),
      py::arg("sinks") = py::none(), py::arg("normals") = py::none(), py::arg("scale_multiplier") = py::none(),
      py::arg("camera_position") = py::none(), py::arg("blend_threshold") = py::none(), py::arg("lambda_") = 1.0,
      py::arg("allow_oversized") = false, py::arg("cancel") = py::none(), py::arg("pack_sets") = false,
      py::arg("coherence_threshold") = texsynth::SearchParams().coherence_threshold,
      py::arg("seeds_per_component") = texsynth::TextonSynthParams().seeds_per_component,
      py::arg("fallback_search") = texsynth::SearchParams().fallback_search,
      "Texton-string patch synthesis (Magda & Kriegman 2003) on a Blender-layout mesh. sample_pixels: the (H, W[, C]) "
      "float image given to preprocess (for E_t). scale = texels per object unit.\n"
      "Returns dict with synthesize_jumpmap's keys (base_uv, blend_uv, blend_weights, num_blend_sets, stats) plus "
      "edge_vertices (E, 2) int32, edge_error E_t (E,), edge_phi Φ = lambda_*E_t*d/|camera - midpoint| (E,; NaN "
      "without camera_position), edge_blended (E,) bool, corner_edge_blended (L,) bool and corner_edge_error (L,) "
      "for the edge from each corner to the next, face_region (F,) int32 (growth region, -1 = border pass). "
      "coherence_threshold: take a neighbour's exact continuation without voting when its Eq. 2 error per string "
      "point is below this fraction of the mean texton distance (0 = always vote). seeds_per_component: growth "
      "regions per component (one per 256 faces at most), grown in parallel (1 = sequential). fallback_search: a face "
      "no vote places inside a non-tileable sample takes the origin of least Eq. 2 error in reach (False = the "
      "neighbour's continuation clamped into the sample). blend_threshold (needs camera_position): blend only edges with "
      "Φ > threshold. ValueError on bad input. cancel: a CancelToken; raising it from another thread stops the call "
      "with Cancelled within milliseconds.");

  m.def(
      "edge_continuity_error",
      [](py::object sample_pixels, py::object positions, py::object corner_verts, py::object poly_starts,
         py::object poly_sizes, py::object base_uv, bool tileable) {
        MeshArrays arrays = mesh_arrays(positions, corner_verts, poly_starts, poly_sizes);
        FloatArray pixels = float_array(sample_pixels, "sample_pixels");
        const texsynth::SampleImage sample = sample_image(pixels);
        if (sample.channels < 1 || sample.channels > 4 || sample.width < 1 || sample.height < 1)
          throw std::invalid_argument("sample_pixels must be a non-empty image with 1 to 4 channels");
        for (py::ssize_t i = 0; i < pixels.size(); ++i)
          if (!std::isfinite(pixels.data()[i])) throw std::invalid_argument("sample_pixels has NaN or infinite values");
        FloatArray uv = float_array(base_uv, "base_uv");
        require_shape(uv, {arrays.input.num_corners, 2}, "base_uv");
        texsynth::MeshEdges edges;
        std::vector<float> error;
        {
          py::gil_scoped_release release;
          texsynth::Mesh mesh = texsynth::build_mesh(arrays.input);
          edges = texsynth::build_mesh_edges(mesh);
          error = texsynth::edge_continuity_error(mesh, edges, uv.data(), sample, tileable);
        }
        const py::ssize_t E = edges.num_edges();
        return py::make_tuple(edge_vertex_array(std::move(edges.vertices)), to_numpy(std::move(error), {E}));
      },
      py::arg("sample_pixels"), py::arg("positions"), py::arg("corner_verts"), py::arg("poly_starts"),
      py::arg("poly_sizes"), py::arg("base_uv"), py::kw_only(), py::arg("tileable") = false,
      "Texture continuity error E_t per mesh edge for any method's base_uv (L, 2): mean colour distance along the edge "
      "between the two faces' mappings (bilinear, texel spacing; boundary edges 0, non-manifold: worst pair). "
      "Returns (edge_vertices (E, 2) int32 sorted, edge_error (E,) float32).");
}
