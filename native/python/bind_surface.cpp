// SPDX-License-Identifier: GPL-3.0-or-later
// Surface samples of an image target (texel centres through a UV map) and bake-margin dilation.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <string>

#include "array_args.hpp"
#include "call_helpers.hpp"
#include "cancel_arg.hpp"
#include "texsynth/surface/dilate.hpp"
#include "texsynth/surface/texel_samples.hpp"

namespace py = pybind11;
using namespace texsynth_py;

namespace {

// (H, W) coverage mask: bool, or integers where non-zero = covered. Floats are refused (0.5 is ambiguous).
py::array_t<bool, py::array::c_style | py::array::forcecast> mask_array(py::handle obj, const char* name) {
  py::array raw = py::array::ensure(obj);
  if (!raw) throw std::invalid_argument(std::string(name) + " must be array-like");
  const char kind = raw.dtype().kind();
  if (kind != 'b' && kind != 'i' && kind != 'u')
    throw std::invalid_argument(std::string(name) + " must be bool or integer, not dtype " +
                                std::string(py::str(raw.dtype())));
  if (kind != 'b') raw = py::module_::import("numpy").attr("not_equal")(raw, 0);  // not a wrapping cast
  return py::array_t<bool, py::array::c_style | py::array::forcecast>::ensure(raw);
}

// A numpy array owning `v` (no copy), for the samples' uninitialised-allocator vectors.
template <class T>
py::array_t<T> owned_array(texsynth::UninitializedVector<T>&& v, std::vector<py::ssize_t> shape) {
  auto* heap = new texsynth::UninitializedVector<T>(std::move(v));
  py::capsule owner(heap, [](void* p) { delete static_cast<texsynth::UninitializedVector<T>*>(p); });
  return py::array_t<T>(shape, heap->data(), owner);
}

}  // namespace

void bind_surface(py::module_& m) {
  m.def(
      "sample_texels",
      [](py::object positions, py::object triangles, py::object corner_uvs, int32_t width, int32_t height,
         int32_t margin, py::object corner_normals, py::object cancel) {
        FloatArray pos = float_array(positions, "positions");
        IntArray tris = int_array(triangles, "triangles");
        FloatArray uvs = float_array(corner_uvs, "corner_uvs");
        require_shape(pos, {-1, 3}, "positions");
        require_shape(tris, {-1, 3}, "triangles");
        const int32_t nt = checked_count(tris.shape(0), "triangles");
        require_shape(uvs, {nt, 3, 2}, "corner_uvs");
        FloatArray normals;
        if (!corner_normals.is_none()) {
          normals = float_array(corner_normals, "corner_normals");
          require_shape(normals, {nt, 3, 3}, "corner_normals");
        }
        texsynth::TexelSampleInput in;
        in.positions = pos.data();
        in.num_vertices = checked_count(pos.shape(0), "positions");
        in.triangles = tris.data();
        in.num_triangles = nt;
        in.corner_uvs = uvs.data();
        in.corner_normals = corner_normals.is_none() ? nullptr : normals.data();
        in.width = width;
        in.height = height;
        in.margin = margin;
        texsynth::TexelSamples s = cancellable(cancel, [&](const CallControl& control) {
          return texsynth::sample_texels(in, control.cancel);
        }, false);
        const py::ssize_t n = py::ssize_t(s.size()), g = py::ssize_t(s.gutter_texel.size());
        py::dict d;
        d["texel"] = owned_array(std::move(s.texel), {n});
        d["triangle"] = owned_array(std::move(s.triangle), {n});
        d["barycentric"] = owned_array(std::move(s.barycentric), {n, 2});
        d["position"] = owned_array(std::move(s.position), {n, 3});
        d["normal"] = owned_array(std::move(s.normal), {n, 3});
        d["island"] = owned_array(std::move(s.island), {n});
        d["gutter_texel"] = to_numpy(std::move(s.gutter_texel), {g});
        d["gutter_source"] = to_numpy(std::move(s.gutter_source), {g});
        d["triangle_island"] = to_numpy(std::move(s.triangle_island), {py::ssize_t(nt)});
        d["num_overlapping_texels"] = s.num_overlapping_texels;
        d["num_degenerate_triangles"] = s.num_degenerate_triangles;
        d["num_islands"] = s.num_islands;
        return d;
      },
      py::arg("positions"), py::arg("triangles"), py::arg("corner_uvs"), py::arg("width"), py::arg("height"),
      py::arg("margin") = 2, py::arg("corner_normals") = py::none(), py::kw_only(), py::arg("cancel") = py::none(),
      "Texel centres of a width x height image covered by a UV-mapped triangle mesh (Blender loop triangles: "
      "positions (V, 3), triangles (T, 3) vertex indices, corner_uvs (T, 3, 2), optional corner_normals (T, 3, 3), "
      "else area-weighted vertex normals). Texel (x, y) is at UV ((x + 0.5) / width, (y + 0.5) / height), index "
      "y * width + x. Returns a dict sorted by texel: texel, triangle, barycentric (N, 2) = weights of corners 1 "
      "and 2, position (N, 3), normal (N, 3), island; gutter_texel / gutter_source (index into the samples of the "
      "nearest covered texel) for uncovered texels within margin texels (Euclidean); triangle_island (T,) (-1 for "
      "degenerate triangles); num_overlapping_texels (texels covered twice; samples keep the lowest triangle), "
      "num_degenerate_triangles (zero-area UV triangles, skipped), num_islands. ValueError for bad shapes, "
      "NaN/Inf, out-of-range indices or an image over the memory limit (see estimate_texel_sample_bytes).");

  m.def(
      "estimate_texel_sample_bytes",
      [](int64_t width, int64_t height) { return texsynth::estimate_texel_sample_bytes(width, height); },
      py::arg("width"), py::arg("height"),
      "Upper bound of the memory sample_texels needs for a width x height image, in bytes. "
      "Images above texel_sample_byte_limit are refused.");
  m.attr("texel_sample_byte_limit") = texsynth::kMaxTexelSampleBytes;

  m.def(
      "dilate_margin",
      [](py::object image, py::object mask, int32_t margin, py::object cancel) {
        FloatArray img = float_array(image, "image");
        if (img.ndim() != 3) {
          std::string got = "(";
          for (py::ssize_t i = 0; i < img.ndim(); ++i) got += (i ? ", " : "") + std::to_string(img.shape(i));
          throw std::invalid_argument("image must have shape (height, width, channels), got " + got + ")");
        }
        const int32_t h = checked_count(img.shape(0), "image"), w = checked_count(img.shape(1), "image");
        const int32_t c = checked_count(img.shape(2), "image");
        auto covered = mask_array(mask, "mask");
        require_shape(covered, {h, w}, "mask");
        std::vector<float> out = cancellable(cancel, [&](const CallControl& control) {
          return texsynth::dilate_margin(img.data(), reinterpret_cast<const uint8_t*>(covered.data()), w, h, c, margin,
                                         control.cancel);
        }, false);
        return to_numpy(std::move(out), {py::ssize_t(h), py::ssize_t(w), py::ssize_t(c)});
      },
      py::arg("image"), py::arg("mask"), py::arg("margin"), py::kw_only(), py::arg("cancel") = py::none(),
      "Bake margin: a new float32 (H, W, C) image (RGBA: C = 4) where every pixel not covered by mask (H, W) "
      "(bool, or integers: non-zero = covered) but within margin pixels (Euclidean) of a covered one takes the "
      "values of the nearest covered pixel (ties: lowest index). Covered pixels are copied bit for bit, farther "
      "pixels are left as they were.");
}
