// SPDX-License-Identifier: GPL-3.0-or-later
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <optional>
#include <string>
#include <vector>

#include "../path_arg.hpp"
#include "texsynth/image_files/image_files.hpp"

namespace py = pybind11;

using texsynth_python::require_path;

namespace {

// Decoded pixels as float32 H×W×C owned by the returned array (no copy).
py::array_t<float> pixel_array(texsynth::Image& image) {
  auto* pixels = new std::vector<float>(std::move(image.pixels));
  py::capsule owner(pixels, [](void* p) { delete static_cast<std::vector<float>*>(p); });
  return py::array_t<float>({py::ssize_t(image.height), py::ssize_t(image.width), py::ssize_t(image.channels)},
                            pixels->data(), owner);
}

texsynth::Image load_released(const std::string& path) {
  py::gil_scoped_release release;
  return texsynth::load_image(path);
}

}  // namespace

void bind_image_files(py::module_& m) {
  m.def(
      "load_image",
      [](py::object path_like) {
        texsynth::Image image = load_released(require_path(path_like, "load_image"));
        return pixel_array(image);
      },
      py::arg("path"),
      "Decodes an image file (any OpenImageIO format) to float32 H×W×C, values as decoded "
      "(8/16-bit data normalised to [0, 1]), row 0 = top.");
  m.def(
      "decode_image",
      [](py::object path_like) {
        texsynth::Image image = load_released(require_path(path_like, "decode_image"));
        const char* encoding = image.encoding == texsynth::ColorEncoding::kLinear ? "linear" : "srgb";
        return py::make_tuple(pixel_array(image), encoding);
      },
      py::arg("path"),
      "load_image plus how the values are encoded: (pixels, \"srgb\" | \"linear\"), integer data being sRGB "
      "and float data linear; the file is opened once.");
  m.def(
      "image_info",
      [](py::object path_like) {
        const std::string path = require_path(path_like, "image_info");
        texsynth::ImageInfo info;
        {
          py::gil_scoped_release release;
          info = texsynth::read_image_info(path);
        }
        py::dict d;
        d["width"] = info.width;
        d["height"] = info.height;
        d["channels"] = info.channels;
        d["format"] = info.format;
        d["data_type"] = info.data_type;
        return d;
      },
      py::arg("path"), "Image header: dict(width, height, channels, format, data_type) without decoding pixels.");
  m.def(
      "write_image_u8",
      [](py::object path_like, py::array_t<uint8_t, py::array::c_style | py::array::forcecast> pixels) {
        const std::string path = require_path(path_like, "write_image_u8");
        if (pixels.ndim() != 3 || pixels.shape(2) < 1 || pixels.shape(2) > 4 || pixels.shape(0) < 1 ||
            pixels.shape(1) < 1)
          throw std::invalid_argument("write_image_u8 expects an H×W×C uint8 array with C in 1..4");
        const int height = int(pixels.shape(0)), width = int(pixels.shape(1)), channels = int(pixels.shape(2));
        const uint8_t* data = pixels.data();
        py::gil_scoped_release release;
        texsynth::write_image_u8(path, data, width, height, channels);
      },
      py::arg("path"), py::arg("pixels"),
      "Writes H×W×C uint8 pixels (row 0 = top) to an image file; the format comes from the extension.");
}
