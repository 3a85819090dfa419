// SPDX-License-Identifier: GPL-3.0-or-later
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstring>

#include "image_arg.hpp"
#include "texsynth/image/image.hpp"

namespace py = pybind11;

namespace texsynth_python {

std::optional<std::string> as_path(py::handle object) {
  if (py::isinstance<py::str>(object)) return object.cast<std::string>();
  if (py::hasattr(object, "__fspath__")) {
    py::object path = py::module_::import("os").attr("fspath")(object);
    if (py::isinstance<py::str>(path)) return path.cast<std::string>();
    throw std::invalid_argument("image path must be text, not bytes");
  }
  return std::nullopt;
}

namespace {

texsynth::Image decode(py::handle object) {
  if (auto path = as_path(object)) {
    py::gil_scoped_release release;
    return texsynth::load_image(*path);
  }
  if (!py::isinstance<py::array>(object))
    throw std::invalid_argument("image must be a file path or a numpy array, got " +
                                std::string(py::str(py::type::of(object))));
  py::array array = py::reinterpret_borrow<py::array>(object);
  if (array.ndim() != 2 && array.ndim() != 3)
    throw std::invalid_argument("image array must be H×W or H×W×C, got " + std::to_string(array.ndim()) + " dimensions");
  const py::ssize_t height = array.shape(0), width = array.shape(1);
  const py::ssize_t channels = array.ndim() == 3 ? array.shape(2) : 1;
  if (height > texsynth::kMaxImageSide || width > texsynth::kMaxImageSide)
    throw std::invalid_argument("image array is too large");
  texsynth::PixelType type;
  const py::dtype dtype = array.dtype();
  if (dtype.is(py::dtype::of<uint8_t>())) {
    type = texsynth::PixelType::kUint8;
  } else if (dtype.is(py::dtype::of<uint16_t>())) {
    type = texsynth::PixelType::kUint16;
  } else if (dtype.is(py::dtype("float16"))) {
    type = texsynth::PixelType::kFloat16;
  } else if (dtype.is(py::dtype::of<float>())) {
    type = texsynth::PixelType::kFloat32;
  } else {
    throw std::invalid_argument("image array dtype " + std::string(py::str(py::object(dtype))) +
                                " is not supported; use uint8, uint16, float16 or float32");
  }
  // Contiguous copy in native byte order (a no-op for already C-contiguous arrays).
  py::array contiguous = py::array::ensure(array, py::array::c_style);
  if (!contiguous) throw std::invalid_argument("image array cannot be made contiguous");
  const void* data = contiguous.data();
  py::gil_scoped_release release;
  return texsynth::image_from_pixels(data, type, int(width), int(height), int(channels));
}

}  // namespace

texsynth::Image image_from_python(py::handle object, const std::string& color_space) {
  if (color_space != "auto" && color_space != "srgb" && color_space != "linear")
    throw std::invalid_argument("color_space must be \"auto\", \"srgb\" or \"linear\", got \"" + color_space + "\"");
  texsynth::Image image = decode(object);
  if (color_space == "srgb") image.encoding = texsynth::ColorEncoding::kSrgb;
  if (color_space == "linear") image.encoding = texsynth::ColorEncoding::kLinear;
  return image;
}

}  // namespace texsynth_python

void bind_image(py::module_& m) {
  m.def(
      "load_image",
      [](py::object path_like) {
        auto path = texsynth_python::as_path(path_like);
        if (!path) throw std::invalid_argument("load_image expects a str or os.PathLike path");
        texsynth::Image image;
        {
          py::gil_scoped_release release;
          image = texsynth::load_image(*path);
        }
        auto* pixels = new std::vector<float>(std::move(image.pixels));
        py::capsule owner(pixels, [](void* p) { delete static_cast<std::vector<float>*>(p); });
        return py::array_t<float>({py::ssize_t(image.height), py::ssize_t(image.width), py::ssize_t(image.channels)},
                                  pixels->data(), owner);
      },
      py::arg("path"),
      "Decodes an image file (any OpenImageIO format) to float32 H×W×C, values as decoded "
      "(8/16-bit data normalised to [0, 1]), row 0 = top.");
  m.def(
      "image_info",
      [](py::object path_like) {
        auto path = texsynth_python::as_path(path_like);
        if (!path) throw std::invalid_argument("image_info expects a str or os.PathLike path");
        const texsynth::ImageInfo info = texsynth::read_image_info(*path);
        py::dict d;
        d["width"] = info.width;
        d["height"] = info.height;
        d["channels"] = info.channels;
        d["format"] = info.format;
        d["data_type"] = info.data_type;
        return d;
      },
      py::arg("path"), "Image header: dict(width, height, channels, format, data_type) without decoding pixels.");
}
