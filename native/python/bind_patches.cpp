// SPDX-License-Identifier: GPL-3.0-or-later
// Vector-field patches (Chen, Liu & Dong): the traced direction field and its grid patches.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "array_args.hpp"
#include "call_helpers.hpp"
#include "cancel_arg.hpp"
#include "texsynth/patches/exemplar_cache.hpp"
#include "texsynth/patches/grid_patch.hpp"
#include "texsynth/patches/patch_synth.hpp"

namespace py = pybind11;
using namespace texsynth_py;

namespace {

// The parameters patch_exemplar() builds with; patch_exemplar_key() hashes the same ones, so a cache key
// covers every default the add-on does not pass.
texsynth::ExemplarParams exemplar_params(const texsynth::ExemplarSample& sample, int patch_size, bool tileable,
                                         uint64_t seed) {
  texsynth::ExemplarParams params;
  params.patch_size = texsynth::fit_patch_size(sample.width, sample.height, patch_size, tileable);
  params.tileable = tileable;
  params.seed = seed;
  params.full_index = true;
  return params;
}

}  // namespace

void bind_patches(py::module_& m) {
  py::class_<texsynth::PatchField, std::shared_ptr<texsynth::PatchField>>(
      m, "PatchField",
      "A triangle mesh and its direction field prepared for tracing grid patches (patch_field()). Immutable; "
      "trace_grid_patches() may be called any number of times.")
      .def_property_readonly("num_vertices", [](const texsynth::PatchField& f) { return f.positions.size() / 3; })
      .def_property_readonly("num_triangles", [](const texsynth::PatchField& f) { return f.triangles.size() / 3; })
      .def_property_readonly("spacing", [](const texsynth::PatchField& f) { return f.spacing; })
      .def_property_readonly("unset_vertices", [](const texsynth::PatchField& f) { return f.unset_vertices; })
      .def_property_readonly("reused_mesh", [](const texsynth::PatchField& f) { return f.reused_mesh; })
      .def_property_readonly("scale", [](const texsynth::PatchField& f) {
        return to_numpy(std::vector<float>(f.scale), {py::ssize_t(f.scale.size())});
      });

  m.def(
      "patch_field",
      [](py::object positions, py::object triangles, py::object directions, double spacing, py::object density,
         bool magnitude_scale, int32_t max_crossings, double singular_threshold, py::object reuse,
         py::object cancel) {
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
        if (!reuse.is_none()) params.reuse_mesh = &reuse.cast<const texsynth::PatchField&>();
        auto field = std::make_shared<texsynth::PatchField>();
        *field = cancellable(cancel, [&](const CallControl& control) {
          params.cancel = control.cancel;
          return texsynth::build_patch_field(in, params);
        }, false);
        return field;
      },
      py::arg("positions"), py::arg("triangles"), py::arg("directions"), py::kw_only(), py::arg("spacing"),
      py::arg("density") = py::none(), py::arg("magnitude_scale") = false, py::arg("max_crossings") = 64,
      py::arg("singular_threshold") = 1e-3, py::arg("reuse") = py::none(), py::arg("cancel") = py::none(),
      "Prepares a direction field for tracing grid patches: positions (V, 3), triangles (T, 3) (Blender loop "
      "triangles), directions (V, 3) (the texture's up; zero or NaN rows are unset and take the nearest set "
      "vertex's), spacing (world distance of one grid step at scale 1), density (V,) optional scale field "
      "(2 = features half as large), magnitude_scale (the directions' lengths set the step instead), reuse "
      "(a PatchField of the same mesh: its walk mesh is copied, not rebuilt). ValueError on bad input; cancel: a "
      "CancelToken.");

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
        // The token is checked before the GIL is released (it used to be read without the GIL).
        texsynth::GridPatches g = cancellable(cancel, [&](const CallControl& control) {
          return texsynth::trace_grid_patches(field, centres.data(), count, size, control.cancel);
        }, false);
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

  py::class_<texsynth::ExemplarIndex, std::shared_ptr<texsynth::ExemplarIndex>>(
      m, "PatchExemplar",
      "A sample analysed for vector-field patches (patch_exemplar()): appearance space, patch features, PCA "
      "and HNSW indices. save(path) / load_patch_exemplar(path, key).")
      .def_property_readonly("key", [](const texsynth::ExemplarIndex& e) { return e.key; })
      .def_property_readonly("patch_size", [](const texsynth::ExemplarIndex& e) { return e.patch_size; })
      .def_property_readonly("width", [](const texsynth::ExemplarIndex& e) { return e.width; })
      .def_property_readonly("height", [](const texsynth::ExemplarIndex& e) { return e.height; })
      .def_property_readonly("channels", [](const texsynth::ExemplarIndex& e) { return e.channels; })
      .def_property_readonly("tileable", [](const texsynth::ExemplarIndex& e) { return e.tileable; })
      .def_property_readonly("stats", [](const texsynth::ExemplarIndex& e) {
        const texsynth::ExemplarStats& s = e.stats;
        return stats_dict("seconds_appearance", s.seconds_appearance, "seconds_features", s.seconds_features,
                          "seconds_hnsw", s.seconds_hnsw, "seconds_total", s.seconds_total, "index_bytes", s.index_bytes);
      })
      .def("save", [](const texsynth::ExemplarIndex& e, const std::string& path) {
        without_gil([&] { texsynth::save_exemplar_index(e, path); });
      });

  m.def(
      "patch_exemplar",
      [](py::object pixels, int patch_size, bool tileable, uint64_t seed, double max_megabytes,
         py::object cancel) {
        FloatArray px = float_array(pixels, "sample");
        const texsynth::ExemplarSample sample = sample_view<texsynth::ExemplarSample>(px);
        texsynth::ExemplarParams params = exemplar_params(sample, patch_size, tileable, seed);
        params.max_megabytes = max_megabytes;
        auto index = std::make_shared<texsynth::ExemplarIndex>();
        *index = cancellable(cancel, [&](const CallControl& control) {
          params.cancel = control.cancel;
          return texsynth::build_exemplar_index(sample, params);
        }, false);
        return index;
      },
      py::arg("sample"), py::kw_only(), py::arg("patch_size") = 32, py::arg("tileable") = false, py::arg("seed") = 0,
      py::arg("max_megabytes") = texsynth::kExemplarDefaultMaxMegabytes,
      py::arg("cancel") = py::none(),
      "Analyses a sample (H, W, 3|4) float, row 0 = bottom, for vector-field patches: appearance and the "
      "full-patch index. A sample too small for patch_size gets the largest multiple of 4 that fits "
      "(PatchExemplar.patch_size says which). ValueError on bad input; cancel: a CancelToken.");

  m.def(
      "patch_exemplar_key",
      [](py::object pixels, int patch_size, bool tileable, uint64_t seed) {
        FloatArray px = float_array(pixels, "sample");
        const texsynth::ExemplarSample sample = sample_view<texsynth::ExemplarSample>(px);
        return texsynth::exemplar_key(sample, exemplar_params(sample, patch_size, tileable, seed));
      },
      py::arg("sample"), py::kw_only(), py::arg("patch_size") = 32, py::arg("tileable") = false, py::arg("seed") = 0,
      "The key patch_exemplar() with these arguments stores in its PatchExemplar (.key), without building it: "
      "pass it to load_patch_exemplar(path, key) so a file made from other pixels or parameters is refused. "
      "Covers the pixels, size, channels, format version and every parameter (the fitted patch size included).");

  // The add-on checks settings and estimates memory with these, before any work: the limits and the
  // plan live here only.
  m.attr("PATCH_SIZE_RANGE") = py::make_tuple(texsynth::kMinPatchSize, texsynth::kMaxPatchSize);
  m.attr("MAX_PATCH_LEVELS") = texsynth::kMaxPatchLevels;
  m.def(
      "fit_patch_size",
      [](int width, int height, int patch_size, bool tileable) {
        return texsynth::fit_patch_size(width, height, patch_size, tileable);
      },
      py::arg("width"), py::arg("height"), py::arg("patch_size"), py::kw_only(), py::arg("tileable") = false,
      "The patch size patch_exemplar() uses for a width x height sample (smaller when the sample is small). "
      "ValueError for a bad size or a sample too small for any patch.");
  m.def(
      "patch_level_sizes",
      [](int width, int height, int patch_size, bool tileable, const std::string& mode, int levels) {
        texsynth::PatchMode m;
        if (mode == "sampling")
          m = texsynth::PatchMode::kSampling;
        else if (mode == "optimisation" || mode == "optimization")
          m = texsynth::PatchMode::kOptimisation;
        else
          throw std::invalid_argument("mode must be 'sampling' or 'optimisation', got '" + mode + "'");
        const int fitted = texsynth::fit_patch_size(width, height, patch_size, tileable);
        py::list out;
        for (const auto& level : texsynth::patch_level_sizes(width, height, fitted, tileable, m, levels))
          out.append(py::make_tuple(level.width, level.height, level.patch_size));
        return out;
      },
      py::arg("width"), py::arg("height"), py::arg("patch_size"), py::kw_only(), py::arg("tileable") = false,
      py::arg("mode") = "sampling", py::arg("levels") = 1,
      "[(width, height, patch size)] of every exemplar synthesize_patches analyses for this sample, finest "
      "first (patch_size as requested: fitted here as patch_exemplar() does).");
  m.def(
      "estimate_patch_exemplar_bytes",
      [](int width, int height, int channels, int patch_size, bool tileable) {
        texsynth::ExemplarParams params;
        params.patch_size = patch_size;
        params.tileable = tileable;
        return texsynth::estimate_exemplar_bytes(width, height, channels, params);
      },
      py::arg("width"), py::arg("height"), py::arg("channels"), py::arg("patch_size"), py::kw_only(),
      py::arg("tileable") = false,
      "Peak bytes patch_exemplar() needs for this sample (its defaults), without building anything.");

  m.def(
      "load_patch_exemplar",
      [](const std::string& path, py::object key) {
        std::optional<uint64_t> expected;
        if (!key.is_none()) expected = key.cast<uint64_t>();
        auto index = std::make_shared<texsynth::ExemplarIndex>();
        *index = without_gil([&] { return texsynth::load_exemplar_index(path, expected); });
        return index;
      },
      py::arg("path"), py::arg("key") = py::none(),
      "Loads a PatchExemplar saved with save(); CacheError (a ValueError) for a missing, corrupt, truncated or "
      "stale file (another key).");

  m.def(
      "synthesize_patches",
      [](const texsynth::PatchField& field, const texsynth::ExemplarIndex& exemplar, py::object pixels,
         py::object positions, py::object normals, py::object triangles, py::object barycentrics,
         const std::string& mode, uint64_t seed, double centre_spacing, int levels, int boundary_width, double tolerance, int candidates,
         int iterations, double robust_exponent, bool exhaustive, bool discrete, const std::string& vote,
         py::object cancel) {
        FloatArray px = float_array(pixels, "sample");
        const texsynth::ExemplarSample sample = sample_view<texsynth::ExemplarSample>(px);
        FloatArray pos = float_array(positions, "positions");
        require_shape(pos, {-1, 3}, "positions");
        FloatArray nrm;
        if (!normals.is_none()) {
          nrm = float_array(normals, "normals");
          require_shape(nrm, {pos.shape(0), 3}, "normals");
        }
        IntArray tri = int_array(triangles, "triangles");
        require_shape(tri, {pos.shape(0)}, "triangles");
        FloatArray bary = float_array(barycentrics, "barycentrics");
        require_shape(bary, {pos.shape(0), 2}, "barycentrics");
        texsynth::PatchSamples samples;
        samples.positions = pos.data();
        samples.normals = normals.is_none() ? nullptr : nrm.data();
        samples.triangle = tri.data();
        samples.barycentric = bary.data();
        samples.count = checked_count(pos.shape(0), "positions");
        texsynth::SurfacePatchParams params;
        if (mode == "sampling")
          params.synth.mode = texsynth::PatchMode::kSampling;
        else if (mode == "optimisation" || mode == "optimization")
          params.synth.mode = texsynth::PatchMode::kOptimisation;
        else
          throw std::invalid_argument("mode must be 'sampling' or 'optimisation', got '" + mode + "'");
        params.centre_spacing = centre_spacing;
        params.levels = levels;
        params.synth.seed = seed;
        params.synth.boundary_width = boundary_width;
        params.synth.tolerance = tolerance;
        params.synth.candidates = candidates;
        params.synth.iterations = iterations;
        params.synth.robust_exponent = robust_exponent;
        params.synth.exhaustive = exhaustive;
        params.synth.discrete = discrete;
        if (vote == "mean")
          params.synth.vote = texsynth::PatchVote::kNearestMean;
        else if (vote == "patch")
          params.synth.vote = texsynth::PatchVote::kBestPatch;
        else
          throw std::invalid_argument("vote must be 'mean' or 'patch', got '" + vote + "'");
        texsynth::SurfacePatchResult r = cancellable(cancel, [&](const CallControl& control) {
          params.synth.cancel = control.cancel;
          params.synth.progress = control.progress;
          return texsynth::synthesize_patches_on_surface(field, samples, exemplar, sample, params);
        });
        const py::ssize_t n = samples.count, C = r.synth.channels, np = r.patches;
        const auto& st = r.synth.stats;
        py::dict stats = stats_dict(
            "patches", r.patches, "extra_patches", r.extra_patches, "random_patches", st.random_patches,
            "uncovered_samples", st.uncovered_samples, "invalid_grid_points", r.invalid_grid_points,
            "coverage_entries", r.coverage_entries, "extrapolated_samples", r.extrapolated_samples,
            "seconds_centres", r.seconds_centres, "seconds_trace", r.seconds_trace, "seconds_locate", r.seconds_locate,
            "seconds_sampling", st.seconds_sampling, "seconds_optimisation", st.seconds_optimisation,
            "seconds_coarse", r.seconds_coarse, "levels", r.levels, "energy", st.energy, "changed", st.changed);
        py::dict out;
        out["colour"] = to_numpy(std::move(r.synth.colour), {n, C});
        out["source"] = to_numpy(std::move(r.synth.source), {n, 2});
        out["origin"] = to_numpy(std::move(r.synth.origin), {np, 2});
        out["stats"] = stats;
        return out;
      },
      py::arg("field"), py::arg("exemplar"), py::arg("sample"), py::arg("positions"), py::arg("normals"),
      py::arg("triangles"), py::arg("barycentrics"), py::kw_only(), py::arg("mode") = "sampling",
      py::arg("seed") = 0, py::arg("centre_spacing") = 0.5, py::arg("levels") = 3, py::arg("boundary_width") = 4, py::arg("tolerance") = 1.2, py::arg("candidates") = 16,
      py::arg("iterations") = 6, py::arg("robust_exponent") = 0.8, py::arg("exhaustive") = true, py::arg("discrete") = true,
      py::arg("vote") = "patch",
      py::arg("cancel") = py::none(),
      "Vector-field patch synthesis onto N surface samples (positions (N, 3), normals (N, 3) or None, triangles "
      "(N,), barycentrics (N, 2) in the field's mesh): mode 'sampling' (§5) or 'optimisation' (§4.3, from the "
      "sampling result; levels > 1: coarser levels first, each from a sample halved again). Returns dict: colour (N, C), source (N, 2) exemplar pixel coordinates (-1: uncovered), "
      "origin (patches, 2), stats. cancel: a CancelToken, whose progress the call updates.");
}
