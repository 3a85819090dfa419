// SPDX-License-Identifier: GPL-3.0-or-later
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstring>

#include "image_arg.hpp"
#include "texsynth/image/image.hpp"

namespace py = pybind11;

namespace texsynth_python {

namespace {
std::string g_image_io_name = "texsynth_image_io";  // a sibling of this module (set_image_io_package)
}  // namespace

void set_image_io_package(const std::string& package_prefix) { g_image_io_name = package_prefix + "texsynth_image_io"; }

// texsynth_image_io (OpenImageIO), imported on first use. Packages for blender.org builds leave it out:
// there Blender decodes the sample, and a path reaching this module gets a clear error instead.
py::module_ image_io() {
  static PyObject* module = nullptr;  // deliberately leaked, like the exception types in module.cpp
  if (module == nullptr) {
    try {
      module = py::module_::import(g_image_io_name.c_str()).release().ptr();
    } catch (py::error_already_set& error) {
      throw std::invalid_argument("reading or writing image files needs " + g_image_io_name +
                                  " (OpenImageIO), which could not be loaded (" + std::string(error.what()) +
                                  "); pass the decoded pixels as a numpy array instead (inside Blender: "
                                  "bpy.data.images)");
    }
  }
  return py::reinterpret_borrow<py::module_>(module);
}

namespace {

// What load_image always gave: every channel the file has, 8/16-bit data normalised, sRGB for
// integer data and linear for float data (the Image is taken as decoded, not re-validated here).
// One call, so the file is opened once: texsynth_image_io returns the pixels with their encoding.
texsynth::Image decode_file(const std::string& path) {
  py::tuple decoded = image_io().attr("decode_image")(path);
  auto pixels = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(decoded[0]);
  if (!pixels) throw std::invalid_argument("image '" + path + "': decoder returned no float array");
  const std::string encoding = py::str(decoded[1]);
  if (pixels.ndim() != 3) throw std::invalid_argument("image '" + path + "': decoder returned no H×W×C array");
  texsynth::Image image;
  image.height = int(pixels.shape(0));
  image.width = int(pixels.shape(1));
  image.channels = int(pixels.shape(2));
  image.encoding = encoding == "linear" ? texsynth::ColorEncoding::kLinear : texsynth::ColorEncoding::kSrgb;
  image.pixels.assign(pixels.data(), pixels.data() + pixels.size());
  return image;
}

texsynth::Image decode(py::handle object) {
  if (auto path = as_path(object)) return decode_file(*path);
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
  const std::string name = py::str(m.attr("__name__"));
  const size_t dot = name.rfind('.');
  texsynth_python::set_image_io_package(dot == std::string::npos ? "" : name.substr(0, dot + 1));
  m.def(
      "load_image", [](py::object path) { return texsynth_python::image_io().attr("load_image")(path); },
      py::arg("path"),
      "Decodes an image file to float32 H×W×C (row 0 = top), through texsynth_image_io (OpenImageIO); "
      "ValueError where that module is not part of the build.");
  m.def(
      "image_info", [](py::object path) { return texsynth_python::image_io().attr("image_info")(path); },
      py::arg("path"),
      "Image header: dict(width, height, channels, format, data_type), through texsynth_image_io.");
}
