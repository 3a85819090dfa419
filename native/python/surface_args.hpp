// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// numpy arguments for points on a surface (triangle + barycentrics), shared by the particle bindings.
// Barycentrics and lengths stay double: particles chain walks.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "array_args.hpp"
#include "texsynth/particles/surface_walk.hpp"

namespace texsynth_py {

using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

inline DoubleArray double_array(py::handle obj, const char* name) {
  py::array raw = py::array::ensure(obj);
  if (!raw) throw std::invalid_argument(std::string(name) + " must be array-like");
  const char kind = raw.dtype().kind();
  if (kind == 'O' || kind == 'U' || kind == 'S') throw std::invalid_argument(std::string(name) + " must be numeric");
  return DoubleArray::ensure(raw);
}

// Points from triangles (n,) and barycentrics (n, 2) (of corners 1 and 2); n = -1 takes any length.
inline std::vector<texsynth::SurfacePoint> surface_points(py::handle triangles, py::handle barycentrics,
                                                          const char* tname, const char* bname, py::ssize_t n) {
  IntArray t = int_array(triangles, tname);
  DoubleArray b = double_array(barycentrics, bname);
  require_shape(t, {n}, tname);
  require_shape(b, {t.shape(0), 2}, bname);
  std::vector<texsynth::SurfacePoint> out(size_t(t.shape(0)));
  for (size_t i = 0; i < out.size(); ++i) out[i] = {t.data()[i], b.data()[2 * i], b.data()[2 * i + 1]};
  return out;
}

}  // namespace texsynth_py
