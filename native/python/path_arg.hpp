// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Path arguments as both Python modules take them (texsynth_native and texsynth_image_io are separate
// shared objects, so this is header-only rather than a symbol one of them exports).
#include <pybind11/pybind11.h>

#include <optional>
#include <stdexcept>
#include <string>

namespace texsynth_python {

// A str/os.PathLike as a filesystem path, or nullopt when `object` is not path-like.
inline std::optional<std::string> as_path(pybind11::handle object) {
  if (pybind11::isinstance<pybind11::str>(object)) return object.cast<std::string>();
  if (pybind11::hasattr(object, "__fspath__")) {
    pybind11::object path = pybind11::module_::import("os").attr("fspath")(object);
    if (pybind11::isinstance<pybind11::str>(path)) return path.cast<std::string>();
    throw std::invalid_argument("image path must be text, not bytes");
  }
  return std::nullopt;
}

// as_path, or std::invalid_argument (ValueError) naming the function that needed a path.
inline std::string require_path(pybind11::handle object, const char* function) {
  if (auto path = as_path(object)) return *path;
  throw std::invalid_argument(std::string(function) + " expects a str or os.PathLike path");
}

}  // namespace texsynth_python
