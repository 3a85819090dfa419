// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Shared by the bindings: turns a Python path (str/PathLike) or numpy array into a texsynth::Image.
#include <pybind11/pybind11.h>

#include <optional>
#include <string>

#include "path_arg.hpp"
#include "texsynth/image/image.hpp"

namespace texsynth_python {

// The sibling module texsynth_image_io (OpenImageIO), imported on first use; std::invalid_argument naming
// it where the build has none (packages for blender.org builds). The prefix is the package this module
// was imported from ("texsynth." inside Blender's add-on, "" on sys.path).
pybind11::module_ image_io();
void set_image_io_package(const std::string& package_prefix);

// Path -> decoded file (through image_io()); ndarray (H×W or H×W×C, uint8/uint16/float16/float32) -> pixels.
// color_space: "auto" (integer data sRGB, float data linear), "srgb" or "linear" (e.g. Blender's float
// pixels of an 8-bit sRGB image are still sRGB-encoded). Throws std::invalid_argument (ValueError).
texsynth::Image image_from_python(pybind11::handle object, const std::string& color_space = "auto");

}  // namespace texsynth_python
