// SPDX-License-Identifier: GPL-3.0-or-later
// Round-neighbourhood synthesis (Chen & Dong 2008): a direction-invariant RoundSynthesisContext
// built once per mesh / UV map / target / scale, and round_synthesize(context, sample, directions)
// that a new direction field re-runs without rebuilding the rings.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "array_args.hpp"
#include "call_helpers.hpp"
#include "cancel_arg.hpp"
#include "texsynth/synth/round_synth.hpp"

namespace py = pybind11;
using namespace texsynth_py;

namespace {

using Context = texsynth::RoundSynthesisContext;

std::string shape_of(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) s += (i ? ", " : "") + std::to_string(a.shape(i));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

py::dict context_stats(const Context& c) {
  std::vector<int32_t> points, rings;
  for (const texsynth::RoundLevel& L : c.levels) points.push_back(L.num_points), rings.push_back(L.rings);
  const auto& s = c.stats;
  return stats_dict("seconds_points", s.seconds_points, "seconds_rings", s.seconds_rings, "seconds_order",
                    s.seconds_order, "seconds_total", s.seconds_total, "estimated_bytes", s.estimated_bytes,
                    "context_bytes", c.context_bytes, "invalid_ring_fraction", s.invalid_ring_fraction,
                    "overlapping_texels", s.overlapping_texels, "level_points", points, "level_rings", rings);
}

std::unique_ptr<Context> make_context(py::object positions, py::object triangles, py::object corner_uvs,
                                      const std::string& target, int32_t width, int32_t height, int32_t margin,
                                      double texels_per_unit, py::object scale_multiplier, int levels, int coarse_rings,
                                      int fine_rings, double facing_limit_degrees, double max_megabytes,
                                      double max_overlap_fraction, py::object cancel) {
  FloatArray pos = float_array(positions, "positions");
  IntArray tris = int_array(triangles, "triangles");
  require_shape(pos, {-1, 3}, "positions");
  require_shape(tris, {-1, 3}, "triangles");
  const int32_t nv = checked_count(pos.shape(0), "positions"), nt = checked_count(tris.shape(0), "triangles");
  texsynth::RoundContextParams p;
  if (target == "image") p.target = texsynth::RoundTarget::kImage;
  else if (target == "vertices") p.target = texsynth::RoundTarget::kVertices;
  else throw std::invalid_argument("target must be 'image' or 'vertices', got '" + target + "'");
  FloatArray uvs;
  if (p.target == texsynth::RoundTarget::kImage) {
    if (corner_uvs.is_none()) throw std::invalid_argument("corner_uvs (T, 3, 2) are required for target='image'");
    uvs = float_array(corner_uvs, "corner_uvs");
    require_shape(uvs, {nt, 3, 2}, "corner_uvs");
  }
  FloatArray mult = optional_scale_multiplier(scale_multiplier, nv);
  texsynth::RoundMeshInput mesh;
  mesh.positions = pos.data();
  mesh.num_vertices = nv;
  mesh.triangles = tris.data();
  mesh.num_triangles = nt;
  mesh.corner_uvs = p.target == texsynth::RoundTarget::kImage ? uvs.data() : nullptr;
  p.width = width;
  p.height = height;
  p.margin = margin;
  p.texels_per_unit = texels_per_unit;
  p.scale_multiplier = scale_multiplier.is_none() ? nullptr : mult.data();
  p.levels = levels;
  p.coarse_rings = coarse_rings;
  p.fine_rings = fine_rings;
  p.facing_limit_degrees = facing_limit_degrees;
  p.max_megabytes = max_megabytes;
  p.max_overlap_fraction = max_overlap_fraction;
  auto ctx = std::make_unique<Context>();
  *ctx = cancellable(cancel, [&](const CallControl& control) {
    p.cancel = control.cancel;
    p.progress = control.progress;
    return texsynth::build_round_context(mesh, p);
  });
  return ctx;
}

py::dict synthesize(const Context& ctx, py::object sample, py::object directions, uint64_t seed, int random_candidates,
                    int dist_range, bool tileable, int min_top_size, int fixed_top_size, double coarse_blur,
                    double coarse_sharp_share, double max_megabytes, py::object cancel) {
  FloatArray img = float_array(sample, "sample");
  if (img.ndim() != 3 || (img.shape(2) != 3 && img.shape(2) != 4))
    throw std::invalid_argument("sample must have shape (height, width, 3 or 4), got " + shape_of(img));
  FloatArray dirs = float_array(directions, "directions");
  require_shape(dirs, {ctx.num_vertices, 3}, "directions");
  texsynth::RoundSample s;
  s.pixels = img.data();
  s.height = checked_count(img.shape(0), "sample");
  s.width = checked_count(img.shape(1), "sample");
  s.channels = int32_t(img.shape(2));
  texsynth::RoundSynthParams p;
  p.seed = seed;
  p.random_candidates = random_candidates;
  p.dist_range = dist_range;
  p.tileable = tileable;
  p.min_top_size = min_top_size;
  p.fixed_top_size = fixed_top_size;
  p.coarse_blur = coarse_blur;
  p.coarse_sharp_share = coarse_sharp_share;
  p.max_megabytes = max_megabytes;
  texsynth::RoundSynthResult r = cancellable(cancel, [&](const CallControl& control) {
    p.cancel = control.cancel;
    p.progress = control.progress;
    return texsynth::synthesize_round(ctx, s, dirs.data(), p);
  });
  const py::ssize_t n = r.num_points, C = r.channels;
  py::dict out;
  if (ctx.target == texsynth::RoundTarget::kVertices) {
    std::vector<float> vc(size_t(ctx.num_vertices) * size_t(C), 0.f);
    for (py::ssize_t i = 0; i < n; ++i)
      for (py::ssize_t k = 0; k < C; ++k) vc[size_t(r.point_id[i]) * C + k] = r.colour[size_t(i) * C + k];
    out["vertex_colour"] = to_numpy(std::move(vc), {py::ssize_t(ctx.num_vertices), C});
  } else {
    out["image"] = to_numpy(std::move(r.image), {py::ssize_t(ctx.height), py::ssize_t(ctx.width), C});
    out["mask"] = to_numpy(std::move(r.mask), {py::ssize_t(ctx.height), py::ssize_t(ctx.width)});
  }
  out["colour"] = to_numpy(std::move(r.colour), {n, C});
  out["source"] = to_numpy(std::move(r.source), {n, py::ssize_t(2)});
  out["point_id"] = to_numpy(std::move(r.point_id), {n});
  py::list levels;
  for (const texsynth::RoundLevelStats& l : r.stats.levels)
    levels.append(stats_dict("points", l.points, "seconds", l.seconds, "candidates_per_point", l.candidates_per_point,
                             "invalid_ring_fraction", l.invalid_ring_fraction, "uncoloured_template_fraction",
                             l.uncoloured_template_fraction, "top_size_histogram", l.top_size_histogram, "reseeds",
                             l.reseeds));
  const auto& st = r.stats;
  out["stats"] = stats_dict("seconds_prepare", st.seconds_prepare, "seconds_output", st.seconds_output,
                            "seconds_total", st.seconds_total, "ring_builds", st.ring_builds, "undefined_directions",
                            st.undefined_directions, "sample_width", st.sample_width, "sample_height", st.sample_height,
                            "estimated_bytes", st.estimated_bytes, "levels", levels);
  return out;
}

}  // namespace

void bind_round(py::module_& m) {
  py::class_<Context, std::shared_ptr<Context>>(
      m, "RoundSynthesisContext",
      "Direction-invariant part of round-neighbourhood synthesis (Chen & Dong 2008): surface points per level, "
      "parents and round rings for a mesh (Blender loop triangles), a target and a scale. Build once, then call "
      "round_synthesize() for each direction field or sample.")
      .def(py::init(&make_context), py::arg("positions"), py::arg("triangles"), py::arg("corner_uvs") = py::none(),
           py::kw_only(), py::arg("target") = "image", py::arg("width") = 0, py::arg("height") = 0,
           py::arg("margin") = 2, py::arg("texels_per_unit"), py::arg("scale_multiplier") = py::none(),
           py::arg("levels") = 3, py::arg("coarse_rings") = 4, py::arg("fine_rings") = 2,
           py::arg("facing_limit_degrees") = 75.0, py::arg("max_megabytes") = texsynth::kRoundDefaultMaxMegabytes,
           py::arg("max_overlap_fraction") = 0.01, py::arg("cancel") = py::none(),
           "positions (V, 3), triangles (T, 3), corner_uvs (T, 3, 2) (target='image'), target 'image' (width x "
           "height texels, margin texels of bake margin) or 'vertices'; texels_per_unit = sample pixels per world "
           "unit (times scale_multiplier (V,) > 0). levels 1..6, coarse_rings (K at the coarsest level) and "
           "fine_rings 1..6. ValueError on bad input, UVs whose overlapping texels exceed max_overlap_fraction of the "
           "covered ones (fewer are accepted and counted in stats['overlapping_texels']) or when the estimated memory exceeds "
           "max_megabytes; cancel: a CancelToken (its progress goes 0..1).")
      .def_property_readonly("target", [](const Context& c) {
        return c.target == texsynth::RoundTarget::kImage ? "image" : "vertices";
      })
      .def_property_readonly("width", [](const Context& c) { return c.width; })
      .def_property_readonly("height", [](const Context& c) { return c.height; })
      .def_property_readonly("num_vertices", [](const Context& c) { return c.num_vertices; })
      .def_property_readonly("num_points", [](const Context& c) { return c.levels[0].num_points; })
      .def_property_readonly("levels", [](const Context& c) { return int(c.levels.size()); })
      .def_property_readonly("stats", &context_stats);

  m.def("round_synthesize", &synthesize, py::arg("context"), py::arg("sample"), py::arg("directions"), py::kw_only(),
        py::arg("seed") = 0, py::arg("random_candidates") = 2, py::arg("dist_range") = 2, py::arg("tileable") = false,
        py::arg("min_top_size") = 2, py::arg("fixed_top_size") = 0,
        py::arg("coarse_blur") = texsynth::RoundSynthParams{}.coarse_blur,
        py::arg("coarse_sharp_share") = texsynth::RoundSynthParams{}.coarse_sharp_share,
        py::arg("max_megabytes") = texsynth::kRoundDefaultMaxMegabytes, py::arg("cancel") = py::none(),
        "Synthesizes `sample` (H, W, 3 or 4) float values as stored (e.g. sRGB), row index growing along the "
        "texture's up (Blender's pixel order), onto the context's points. directions (V, 3): the texture's up per "
        "vertex (zero = undefined: taken from a neighbour). Returns dict: colour (N, C) and source (N, 2) (finest "
        "sample pixels, pixel (x, y) centred at (x + .5, y + .5)) per finest point, point_id (N,) (texel index "
        "y * width + x, or vertex), image (height, width, C) with the bake margin filled and mask (height, width) "
        "uint8 (1 covered, 2 margin) for target 'image', vertex_colour (V, C) for 'vertices', and stats. "
        "random_candidates: per sample pixel at the coarsest level; dist_range: hierarchical window at finer levels; "
        "tileable: the sample wraps; min_top_size: the adaptive metric's first cut size (1 = the paper literally); "
        "fixed_top_size > 0: a fixed metric size instead, for comparisons; coarse_blur: Gaussian sigma (coarsest-level "
        "pixels) of the sample matched at the coarsest level, with coarse_sharp_share of the sharp sample kept (0 = sharp). "
        "Results are identical for a seed whatever the thread count. ValueError on bad input; Cancelled when "
        "cancel (a CancelToken) is raised; its progress goes 0..1.");

  m.def("round_context_ring_builds", &texsynth::round_context_ring_builds,
        "Ring tables built by RoundSynthesisContext so far in this process (round_synthesize builds none).");
}
