// SPDX-License-Identifier: GPL-3.0-or-later
// Texture-particle analysis (particles/analysis.hpp): particle_analysis() and particle_sprite().
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "array_args.hpp"
#include "call_helpers.hpp"
#include "cancel_arg.hpp"
#include "texsynth/particles/analysis.hpp"

namespace py = pybind11;
using namespace texsynth_py;

namespace {

template <class T>
py::array_t<T> copy_array(const std::vector<T>& v, std::vector<py::ssize_t> shape) {
  return to_numpy(std::vector<T>(v), std::move(shape));
}

// A structured array with the given fields filled from plain arrays (name, array) in order.
py::array structured(py::ssize_t n, const std::vector<std::pair<std::string, py::array>>& fields) {
  py::module_ np = py::module_::import("numpy");
  py::list spec;
  for (const auto& [name, a] : fields) {
    py::tuple shape(a.ndim() - 1);
    for (py::ssize_t d = 1; d < a.ndim(); ++d) shape[size_t(d - 1)] = a.shape(d);
    spec.append(py::make_tuple(name, a.dtype(), shape));
  }
  py::array out = np.attr("zeros")(n, np.attr("dtype")(spec));
  for (const auto& [name, a] : fields) out[py::str(name)].attr("__setitem__")(py::ellipsis(), a);
  return out;
}

py::array particles_table(const texsynth::ParticleAnalysis& a) {
  const py::ssize_t n = py::ssize_t(a.particles.size());
  std::vector<int32_t> cls, area, bbox, boundary, border;
  std::vector<float> centroid, centre, angle, half;
  std::vector<uint8_t> complete;
  for (const auto& p : a.particles) {
    cls.push_back(p.class_id), area.push_back(p.area);
    centroid.insert(centroid.end(), {p.centroid_x, p.centroid_y});
    bbox.insert(bbox.end(), {p.x0, p.y0, p.x1, p.y1});
    centre.insert(centre.end(), {p.box.cx, p.box.cy});
    angle.push_back(p.box.angle);
    half.insert(half.end(), {p.box.half_x, p.box.half_y});
    boundary.push_back(p.boundary_pixels), border.push_back(p.border_pixels);
    complete.push_back(p.complete);
  }
  return structured(n, {{"class", to_numpy(std::move(cls), {n})},
                        {"area", to_numpy(std::move(area), {n})},
                        {"centroid", to_numpy(std::move(centroid), {n, 2})},
                        {"bbox", to_numpy(std::move(bbox), {n, 4})},
                        {"box_centre", to_numpy(std::move(centre), {n, 2})},
                        {"box_angle", to_numpy(std::move(angle), {n})},
                        {"box_half", to_numpy(std::move(half), {n, 2})},
                        {"complete", to_numpy(std::move(complete), {n}).attr("astype")("bool")},
                        {"boundary_pixels", to_numpy(std::move(boundary), {n})},
                        {"border_pixels", to_numpy(std::move(border), {n})}});
}

py::array classes_table(const texsynth::ParticleAnalysis& a) {
  const py::ssize_t k = py::ssize_t(a.classes.size()), C = a.channels;
  std::vector<int32_t> pixels, particles, complete;
  std::vector<float> colour;
  std::vector<uint8_t> background, has_complete, random;
  std::vector<double> density, min_distance, tolerance;
  for (const auto& c : a.classes) {
    pixels.push_back(c.pixels), particles.push_back(c.particles), complete.push_back(c.complete);
    colour.insert(colour.end(), c.colour.begin(), c.colour.begin() + C);
    background.push_back(c.background), has_complete.push_back(c.has_complete), random.push_back(c.random);
    density.push_back(c.density), min_distance.push_back(c.min_distance), tolerance.push_back(c.tolerance);
  }
  return structured(k, {{"pixels", to_numpy(std::move(pixels), {k})},
                        {"particles", to_numpy(std::move(particles), {k})},
                        {"complete", to_numpy(std::move(complete), {k})},
                        {"colour", to_numpy(std::move(colour), {k, C})},
                        {"background", to_numpy(std::move(background), {k}).attr("astype")("bool")},
                        {"has_complete", to_numpy(std::move(has_complete), {k}).attr("astype")("bool")},
                        {"random", to_numpy(std::move(random), {k}).attr("astype")("bool")},
                        {"density", to_numpy(std::move(density), {k})},
                        {"min_distance", to_numpy(std::move(min_distance), {k})},
                        {"tolerance", to_numpy(std::move(tolerance), {k})}});
}

py::dict class_pair_arrays(const texsynth::ParticleAnalysis& a) {
  const py::ssize_t k = a.num_classes;
  std::vector<int32_t> pairs;
  std::vector<double> tolerance, margin;
  for (const auto& p : a.class_pairs)
    pairs.push_back(p.pairs), tolerance.push_back(p.tolerance), margin.push_back(p.margin);
  py::dict d;
  d["pairs"] = to_numpy(std::move(pairs), {k, k});
  d["tolerance"] = to_numpy(std::move(tolerance), {k, k});
  d["margin"] = to_numpy(std::move(margin), {k, k});
  return d;
}

py::dict cooccurrence_arrays(const texsynth::ParticleAnalysis& a) {
  const py::ssize_t n = py::ssize_t(a.cooc.size());
  std::vector<int32_t> quadrant, neighbour;
  std::vector<float> dx, dy, angle;
  std::vector<uint8_t> source;
  for (const auto& e : a.cooc) {
    quadrant.push_back(e.quadrant), neighbour.push_back(e.neighbour);
    dx.push_back(e.dx), dy.push_back(e.dy), angle.push_back(e.angle);
    source.push_back(uint8_t(e.source));
  }
  py::dict d;
  d["start"] = copy_array(a.cooc_start, {py::ssize_t(a.cooc_start.size())});
  d["quadrant"] = to_numpy(std::move(quadrant), {n});
  d["dx"] = to_numpy(std::move(dx), {n});
  d["dy"] = to_numpy(std::move(dy), {n});
  d["angle"] = to_numpy(std::move(angle), {n});
  d["neighbour"] = to_numpy(std::move(neighbour), {n});
  d["mirrored"] = to_numpy(std::move(source), {n});
  return d;
}

}  // namespace

void bind_particles(py::module_& m) {
  using texsynth::ParticleAnalysis;
  py::class_<ParticleAnalysis, std::shared_ptr<ParticleAnalysis>>(
      m, "ParticleAnalysis",
      "Result of particle_analysis(). Array properties are fresh copies on each access. Rows: row 0 = bottom.")
      .def_property_readonly("width", [](const ParticleAnalysis& a) { return a.width; })
      .def_property_readonly("height", [](const ParticleAnalysis& a) { return a.height; })
      .def_property_readonly("channels", [](const ParticleAnalysis& a) { return a.channels; })
      .def_property_readonly("tileable", [](const ParticleAnalysis& a) { return a.tileable; })
      .def_property_readonly("touching", [](const ParticleAnalysis& a) { return a.touching; })
      .def_property_readonly("touching_fragments", [](const ParticleAnalysis& a) { return a.touching_fragments; })
      .def_property_readonly("num_classes", [](const ParticleAnalysis& a) { return a.num_classes; })
      .def_property_readonly("background_class", [](const ParticleAnalysis& a) { return a.background; })
      .def_property_readonly("min_area", [](const ParticleAnalysis& a) { return a.min_area; })
      .def_property_readonly("merged_components", [](const ParticleAnalysis& a) { return a.merged_components(); },
                             "Components merged into the background: below min_area plus beyond the 20,000 cap.")
      .def_property_readonly("merged_over_cap", [](const ParticleAnalysis& a) { return a.merged_over_cap; })
      .def_property_readonly("classes_without_complete",
                             [](const ParticleAnalysis& a) { return a.classes_without_complete; })
      .def_property_readonly("labels", [](const ParticleAnalysis& a) {
        return copy_array(a.labels, {a.height, a.width});
      }, "(H, W) int32 class per pixel (after merges).")
      .def_property_readonly("components", [](const ParticleAnalysis& a) {
        return copy_array(a.components, {a.height, a.width});
      }, "(H, W) int32 particle id per pixel, -1 = background.")
      .def_property_readonly("background", [](const ParticleAnalysis& a) {
        return copy_array(a.background_fill, {a.height, a.width, a.channels});
      }, "(H, W, C) float32: the sample with every particle (dilated 2 px) filled by onion peeling.")
      .def_property_readonly("particles", &particles_table,
                             "Structured (n,): class, area, centroid (2), bbox (x0, y0, x1, y1 inclusive), box_centre "
                             "(2), box_angle (radians), box_half (2), complete, boundary_pixels, border_pixels.")
      .def_property_readonly("classes", &classes_table,
                             "Structured (k,): pixels, particles, complete, colour (C), background, has_complete, "
                             "random, density, min_distance, tolerance.")
      .def_property_readonly("class_pairs", &class_pair_arrays,
                             "dict of (k, k) symmetric arrays, what the sample shows between two classes: pairs "
                             "(distinct nearest particle pairs measured), tolerance (overlap tolerance: intersection "
                             "/ smaller box), margin (px: half the 10th-percentile nearest box gap). Placement tests "
                             "a particle against other classes with them.")
      .def_property_readonly("cooccurrences", &cooccurrence_arrays,
                             "dict of CSR arrays: start (n + 1,), then per entry quadrant (0 (+,+), 1 (-,+), 2 (-,-), "
                             "3 (+,-)), dx, dy, angle, neighbour (-1: class median), mirrored (0 measured, 1 opposite, "
                             "2 class median, 3 adjacent reflected).")
      .def_property_readonly("stats", [](const ParticleAnalysis& a) {
        const texsynth::ParticleAnalysisStats& s = a.stats;
        return stats_dict("seconds_blur", s.seconds_blur, "seconds_kmeans", s.seconds_kmeans, "seconds_components",
                          s.seconds_components, "seconds_geometry", s.seconds_geometry, "seconds_cooccurrence",
                          s.seconds_cooccurrence, "seconds_background", s.seconds_background, "seconds_total",
                          s.seconds_total);
      });

  m.def(
      "particle_analysis",
      [](py::object sample, int classes, double blur, py::object min_area, py::object labels, py::object background,
         bool tileable, bool wrap_blur, uint64_t seed, py::object touching, double touching_neck,
         double touching_depth, bool touching_darker, double touching_shading, py::object cancel) {
        FloatArray px = float_array(sample, "sample");
        const texsynth::ParticleSample s = sample_view<texsynth::ParticleSample>(px);
        texsynth::ParticleAnalysisParams p;
        p.classes = classes;
        p.blur_sigma = blur;
        p.min_area = min_area.is_none() ? 0 : min_area.cast<int32_t>();
        if (!min_area.is_none() && p.min_area < 1) throw std::invalid_argument("min_area must be >= 1 or None");
        if (!labels.is_none()) {
          IntArray l = int_array(labels, "labels");
          require_shape(l, {s.height, s.width}, "labels");
          p.labels.assign(l.data(), l.data() + l.size());
        }
        p.background = background.is_none() ? -1 : background.cast<int32_t>();
        if (!background.is_none() && p.background < 0) throw std::invalid_argument("background must be >= 0 or None");
        p.tileable = tileable;
        p.wrap_blur = wrap_blur;
        p.seed = seed;
        if (py::isinstance<py::str>(touching)) {
          if (touching.cast<std::string>() != "auto")
            throw std::invalid_argument("touching must be True, False or 'auto', got '" +
                                        touching.cast<std::string>() + "'");
          p.touching_auto = true;
        } else {
          p.touching = touching.cast<bool>();
        }
        p.touching_neck = touching_neck;
        p.touching_darker = touching_darker;
        p.touching_depth = touching_depth;
        p.touching_shading = touching_shading;
        auto out = std::make_shared<ParticleAnalysis>();
        *out = cancellable(cancel, [&](const CallControl& control) {
          p.cancel = control.cancel;
          p.progress = control.progress;
          return texsynth::analyse_particles(s, p);
        });
        return out;
      },
      py::arg("sample"), py::kw_only(), py::arg("classes") = 4, py::arg("blur") = 1.0, py::arg("min_area") = py::none(),
      py::arg("labels") = py::none(), py::arg("background") = py::none(), py::arg("tileable") = false,
      py::arg("wrap_blur") = true, py::arg("seed") = 0, py::arg("touching") = false,
      py::arg("touching_neck") = texsynth::kParticleTouchingNeck,
      py::arg("touching_depth") = texsynth::kParticleTouchingDepth, py::arg("touching_darker") = true,
      py::arg("touching_shading") = 0.0,
      py::arg("cancel") = py::none(),
      "Texture-particle analysis of a sample (H, W, 3|4) float, row 0 = bottom: Gaussian blur (sigma px) + "
      "k-means++ into `classes` (2..12), or `labels` (H, W) int class per pixel instead; 8-connected particles "
      "(smaller than min_area, default max(16, 0.02 % of the pixels), merged into the background class, which is "
      "the largest unless given); boxes, completeness, co-occurrence lists, class table and the filled "
      "background. tileable: the blur and the particles wrap across the border (wrap_blur=False: the blur "
      "clamps, so the classes are those of an untiled analysis). touching: elements that touch (gravel, "
      "cobbles): background = the class with the largest connected piece (touching_darker: the classes darker "
      "than it join it), the rest split by a distance-transform "
      "watershed: two basins stay apart when their saddle is <= touching_neck (0..1] x the lower peak and that "
      "peak rises >= touching_depth px above it (touching_shading 0..1: the relief is the distance darkened by "
      "the sample's shading, 0 = distance only); 'auto': that split only where one plain particle covers more "
      "than a fifth of the sample, kept unless it leaves a smaller share of complete particles (the analysis' "
      "`touching` says which). Returns a ParticleAnalysis. ValueError on bad input; cancel: a "
      "CancelToken (progress updated).");

  m.def(
      "particle_sprite",
      [](const ParticleAnalysis& analysis, py::object sample, int32_t particle_id) {
        FloatArray px = float_array(sample, "sample");
        const texsynth::ParticleSample s = sample_view<texsynth::ParticleSample>(px);
        texsynth::ParticleSprite sprite = without_gil([&] { return texsynth::particle_sprite(analysis, s, particle_id); });
        py::dict out;
        out["rgba"] = to_numpy(std::move(sprite.rgba), {sprite.height, sprite.width, 4});
        out["origin"] = py::make_tuple(sprite.x0, sprite.y0);
        return out;
      },
      py::arg("analysis"), py::arg("sample"), py::arg("particle_id"),
      "Soft sprite of one particle: dict rgba (h, w, 4) float32 (bbox + 2 px; straight alpha, 1 on the mask, "
      "2/3 and 1/3 on the two rings around it) and origin (x0, y0), the sample pixel under rgba[0, 0] "
      "(unwrapped on tileable samples; may be negative). sample: the analysed one.");
}
