// SPDX-License-Identifier: GPL-3.0-or-later
// Python API of preprocessing. Preprocessed is held by std::shared_ptr, so other bindings
// (bind_synth.cpp) can take `const texsynth::Preprocessed&` arguments directly.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstring>
#include <memory>
#include <optional>

#include "call_helpers.hpp"
#include "cancel_arg.hpp"
#include "image_arg.hpp"
#include "texsynth/image/image.hpp"
#include "texsynth/preprocess/cache.hpp"
#include "texsynth/preprocess/gaussianize.hpp"
#include "texsynth/preprocess/preprocess.hpp"

namespace py = pybind11;
using texsynth::Preprocessed;
using texsynth::PreprocessParams;

namespace {

template <typename T>
py::array_t<T> copy_array(const std::vector<T>& values, std::vector<py::ssize_t> shape) {
  py::array_t<T> out(shape);
  if (!values.empty()) std::memcpy(out.mutable_data(), values.data(), values.size() * sizeof(T));
  return out;
}

// Hands a large result over to numpy without copying it (the capsule frees it with the array).
template <typename T>
py::array_t<T> move_array(std::vector<T>&& values, std::vector<py::ssize_t> shape) {
  auto* owned = new std::vector<T>(std::move(values));
  py::capsule release(owned, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  return py::array_t<T>(shape, owned->data(), release);
}

PreprocessParams make_params(int neighbourhood, int num_textons, int jump_candidates, int feature_dims, bool tileable,
                             uint64_t seed, int working_size) {
  PreprocessParams p;
  p.working_size = working_size;
  p.neighbourhood = neighbourhood;
  p.num_textons = num_textons;
  p.jump_candidates = jump_candidates;
  p.feature_dims = feature_dims;
  p.tileable = tileable;
  p.seed = seed;
  return p;
}

std::string cache_dir_string(py::handle cache_dir) {
  auto dir = texsynth_python::as_path(cache_dir);
  if (!dir) throw std::invalid_argument("cache_dir must be a str or os.PathLike");
  return *dir;
}

py::dict params_dict(const PreprocessParams& p) {
  py::dict d;
  d["neighbourhood"] = p.neighbourhood;
  d["num_textons"] = p.num_textons;
  d["jump_candidates"] = p.jump_candidates;
  d["feature_dims"] = p.feature_dims;
  d["tileable"] = p.tileable;
  d["seed"] = p.seed;
  d["kmeans_change_fraction"] = p.kmeans_change_fraction;
  d["kmeans_max_iterations"] = p.kmeans_max_iterations;
  d["working_size"] = p.working_size;
  return d;
}

#define TEXSYNTH_PARAM_ARGS                                                                                  \
  py::kw_only(), py::arg("neighbourhood") = 11, py::arg("num_textons") = 0, py::arg("jump_candidates") = 4, \
      py::arg("feature_dims") = 16, py::arg("tileable") = false, py::arg("seed") = 0, py::arg("color_space") = "auto", \
      py::arg("working_size") = 512

}  // namespace

void bind_preprocess(py::module_& m) {
  py::class_<Preprocessed, std::shared_ptr<Preprocessed>>(m, "Preprocessed",
                                                          "A preprocessed sample: textons, bucket array, jump map.")
      .def_property_readonly("width", [](const Preprocessed& r) { return r.width; })
      .def_property_readonly("height", [](const Preprocessed& r) { return r.height; })
      .def_property_readonly("sample_width", [](const Preprocessed& r) { return r.sample_width; })
      .def_property_readonly("sample_height", [](const Preprocessed& r) { return r.sample_height; })
      .def_property_readonly("num_textons", [](const Preprocessed& r) { return r.num_textons; })
      .def_property_readonly("texton_dims", [](const Preprocessed& r) { return r.texton_dims; })
      .def_property_readonly("sample_hash", [](const Preprocessed& r) { return r.sample_hash; })
      .def_property_readonly("cache_hit", [](const Preprocessed& r) { return r.cache_hit; })
      .def_property_readonly("cache_status", [](const Preprocessed& r) { return r.cache_status; })
      .def_property_readonly("params", [](const Preprocessed& r) { return params_dict(r.params); })
      .def_property_readonly("texton_map",
                             [](const Preprocessed& r) { return copy_array(r.texton_map, {r.height, r.width}); })
      .def_property_readonly("textons",
                             [](const Preprocessed& r) { return copy_array(r.textons, {r.num_textons, r.texton_dims}); })
      .def_property_readonly(
          "texton_distances",
          [](const Preprocessed& r) { return copy_array(r.texton_distances, {r.num_textons, r.num_textons}); })
      .def_property_readonly("bucket_start",
                             [](const Preprocessed& r) { return copy_array(r.bucket_start, {r.num_textons + 1}); })
      .def_property_readonly("bucket_pixels", [](const Preprocessed& r) {
        return copy_array(r.bucket_pixels, {py::ssize_t(r.bucket_pixels.size())});
      })
      .def_property_readonly("jump_targets",
                             [](const Preprocessed& r) {
                               return copy_array(r.jump_map.targets, {r.height, r.width, r.jump_map.k});
                             })
      .def_property_readonly("jump_weights",
                             [](const Preprocessed& r) {
                               return copy_array(r.jump_map.weights, {r.height, r.width, r.jump_map.k});
                             })
      .def(
          "save",
          [](const Preprocessed& r, py::object path) {
            auto p = texsynth_python::as_path(path);
            if (!p) throw std::invalid_argument("save expects a str or os.PathLike path");
            py::gil_scoped_release release;
            texsynth::save_preprocessed(r, *p);
          },
          py::arg("path"), "Writes the cache file format (atomically).")
      .def(
          "texton_map_image",
          [](const Preprocessed& r) {
            return copy_array(texsynth::texton_map_colors(r), {r.height, r.width, 3});
          },
          "Texton map in pseudo-colours, (H, W, 3) uint8.")
      .def(
          "write_texton_map_image",
          [](const Preprocessed& r, py::object path) {
            auto p = texsynth_python::as_path(path);
            if (!p) throw std::invalid_argument("write_texton_map_image expects a str or os.PathLike path");
            py::module_ io = texsynth_python::image_io();
            io.attr("write_image_u8")(*p, copy_array(texsynth::texton_map_colors(r), {r.height, r.width, 3}));
          },
          py::arg("path"),
          "Writes the pseudo-colour texton map through texsynth_image_io (format from the extension).")
      .def("__repr__", [](const Preprocessed& r) {
        return "<Preprocessed " + std::to_string(r.width) + "x" + std::to_string(r.height) + ", " +
               std::to_string(r.num_textons) + " textons, cache " + r.cache_status + ">";
      });

  m.def(
      "preprocess",
      [](py::object image_arg, int neighbourhood, int num_textons, int jump_candidates, int feature_dims, bool tileable,
         uint64_t seed, const std::string& color_space, int working_size, py::object cache_dir, py::object cancel) {
        const PreprocessParams params =
            make_params(neighbourhood, num_textons, jump_candidates, feature_dims, tileable, seed, working_size);
        texsynth::Image image = texsynth_python::image_from_python(image_arg, color_space);
        std::optional<std::string> dir;
        if (!cache_dir.is_none()) dir = cache_dir_string(cache_dir);
        return texsynth_py::cancellable(cancel, [&](const texsynth_py::CallControl& control) {
          return std::make_shared<Preprocessed>(dir ? texsynth::preprocess_cached(image, params, *dir, control.cancel)
                                                    : texsynth::preprocess(image, params, control.cancel));
        }, false);
      },
      py::arg("image"), TEXSYNTH_PARAM_ARGS, py::arg("cache_dir") = py::none(), py::arg("cancel") = py::none(),
      "Preprocesses a sample (path or numpy array). With cache_dir, a valid cache is loaded instead "
      "(cache_hit=True) and a missing/corrupt one is recomputed and rewritten. cancel: a CancelToken (raises Cancelled).");

  m.def(
      "cache_file_path",
      [](py::object image_arg, py::object cache_dir, int neighbourhood, int num_textons, int jump_candidates,
         int feature_dims, bool tileable, uint64_t seed, const std::string& color_space, int working_size) {
        const PreprocessParams params =
            make_params(neighbourhood, num_textons, jump_candidates, feature_dims, tileable, seed, working_size);
        const texsynth::Image image = texsynth_python::image_from_python(image_arg, color_space);
        return texsynth::cache_file_path(cache_dir_string(cache_dir), texsynth::image_hash(image), params);
      },
      py::arg("image"), py::kw_only(), py::arg("cache_dir"), py::arg("neighbourhood") = 11, py::arg("num_textons") = 0,
      py::arg("jump_candidates") = 4, py::arg("feature_dims") = 16, py::arg("tileable") = false, py::arg("seed") = 0,
      py::arg("color_space") = "auto", py::arg("working_size") = 512, "Where preprocess(image, cache_dir=..., **params) keeps its cache.");

  m.def(
      "cache_status",
      [](py::object image_arg, py::object cache_dir, int neighbourhood, int num_textons, int jump_candidates,
         int feature_dims, bool tileable, uint64_t seed, const std::string& color_space, int working_size) {
        const PreprocessParams params =
            make_params(neighbourhood, num_textons, jump_candidates, feature_dims, tileable, seed, working_size);
        const texsynth::Image image = texsynth_python::image_from_python(image_arg, color_space);
        const uint64_t hash = texsynth::image_hash(image);
        const std::string path = texsynth::cache_file_path(cache_dir_string(cache_dir), hash, params);
        py::gil_scoped_release release;
        switch (texsynth::cache_state(path, hash, params)) {
          case texsynth::CacheState::kFresh: return std::string("fresh");
          case texsynth::CacheState::kMissing: return std::string("missing");
          default: return std::string("stale");
        }
      },
      py::arg("image"), py::kw_only(), py::arg("cache_dir"), py::arg("neighbourhood") = 11, py::arg("num_textons") = 0,
      py::arg("jump_candidates") = 4, py::arg("feature_dims") = 16, py::arg("tileable") = false, py::arg("seed") = 0,
      py::arg("color_space") = "auto", py::arg("working_size") = 512, "\"fresh\" | \"missing\" | \"stale\" for the cache preprocess() would use (computes no textons).");

  m.def(
      "histogram_transform",
      [](py::object image_arg, py::object cache_dir, int lut_size, int min_distinct_values,
         const std::string& color_space) {
        const texsynth::Image image = texsynth_python::image_from_python(image_arg, color_space);
        std::optional<std::string> dir;
        if (!cache_dir.is_none()) dir = cache_dir_string(cache_dir);
        std::optional<std::string> stem;
        texsynth::HistogramTransform t;
        {
          py::gil_scoped_release release;
          if (dir) {
            const uint64_t hash = texsynth::image_hash(image);
            t = texsynth::histogram_transform_cached(image, hash, *dir, lut_size, min_distinct_values);
            stem = texsynth::histogram_file_stem(*dir, hash, lut_size);
          } else {
            t = texsynth::gaussianize(image, lut_size, min_distinct_values);
          }
        }
        py::dict d;
        d["gaussian"] = move_array(std::move(t.gaussian), {t.height, t.width, t.channels});
        d["inverse_lut"] = copy_array(t.inverse_lut, {t.lut_size, t.channels});
        d["ok"] = t.ok;
        d["fallback_reason"] = t.fallback_reason;
        d["colour_channels"] = t.colour_channels;
        d["gaussian_path"] = stem ? py::object(py::str(texsynth::histogram_gaussian_path(*stem))) : py::none();
        d["lut_path"] = stem ? py::object(py::str(texsynth::histogram_lut_path(*stem))) : py::none();
        return d;
      },
      py::arg("sample"), py::kw_only(), py::arg("cache_dir") = py::none(), py::arg("lut_size") = 1024,
      py::arg("min_distinct_values") = 16, py::arg("color_space") = "auto",
      "Histogram-preserving blending support (Heitz & Neyret 2018) for a sample (path or numpy array, as for "
      "preprocess): its colour channels mapped onto a Gaussian (mean 0.5, std 1/6) and the inverse look-up table.\n"
      "Returns a dict: gaussian (H, W, C) float32, inverse_lut (lut_size, C) float32 (entry i is for Gaussian value "
      "(i+0.5)/lut_size), ok, fallback_reason (identity transform when a channel has fewer than "
      "min_distinct_values distinct values), colour_channels, gaussian_path / lut_path (the OpenEXR files "
      "in cache_dir, reused while valid; None without cache_dir).");

  m.def(
      "load_preprocessed",
      [](py::object path, std::optional<uint64_t> expected_hash) {
        auto p = texsynth_python::as_path(path);
        if (!p) throw std::invalid_argument("load_preprocessed expects a str or os.PathLike path");
        py::gil_scoped_release release;
        return std::make_shared<Preprocessed>(texsynth::load_preprocessed(*p, expected_hash));
      },
      py::arg("path"), py::kw_only(), py::arg("expected_hash") = py::none(),
      "Loads a cache file; raises CacheError on any problem (truncated, corrupt, other sample).");
}
