// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// numpy argument helpers shared by bind_mesh/bind_field/bind_synth. Arrays that already have the
// right dtype and are C-contiguous are used in place (no copy); others are converted. Integer
// arrays are range-checked before narrowing to int32 so nothing wraps silently.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "texsynth/mesh/poly_mesh.hpp"

namespace texsynth_py {
namespace py = pybind11;

using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;
using IntArray = py::array_t<int32_t, py::array::c_style | py::array::forcecast>;

inline FloatArray float_array(py::handle obj, const char* name) {
  py::array raw = py::array::ensure(obj);
  if (!raw) throw std::invalid_argument(std::string(name) + " must be array-like");
  if (raw.dtype().kind() == 'O' || raw.dtype().kind() == 'U' || raw.dtype().kind() == 'S')
    throw std::invalid_argument(std::string(name) + " must be numeric");
  return FloatArray::ensure(raw);
}

inline IntArray int_array(py::handle obj, const char* name) {
  py::array raw = py::array::ensure(obj);
  if (!raw) throw std::invalid_argument(std::string(name) + " must be array-like");
  const char kind = raw.dtype().kind();
  if (raw.size() > 0 && kind != 'i' && kind != 'u')
    throw std::invalid_argument(std::string(name) + " must hold integers, not dtype " + std::string(py::str(raw.dtype())));
  if (kind == 'i' && raw.itemsize() == 4) return IntArray::ensure(raw);  // fast path, no copy when contiguous
  auto wide = py::array_t<int64_t, py::array::c_style | py::array::forcecast>::ensure(raw);
  IntArray out(std::vector<py::ssize_t>(wide.shape(), wide.shape() + wide.ndim()));
  const int64_t* src = wide.data();
  int32_t* dst = out.mutable_data();
  for (py::ssize_t i = 0; i < wide.size(); ++i) {
    if (src[i] < std::numeric_limits<int32_t>::min() || src[i] > std::numeric_limits<int32_t>::max())
      throw std::invalid_argument(std::string(name) + "[" + std::to_string(i) + "] = " + std::to_string(src[i]) +
                                  " does not fit in int32");
    dst[i] = int32_t(src[i]);
  }
  return out;
}

inline void require_shape(const py::array& a, std::initializer_list<py::ssize_t> shape, const char* name) {
  bool ok = a.ndim() == py::ssize_t(shape.size());
  size_t d = 0;
  std::string want = "(";
  for (py::ssize_t s : shape) {
    if (ok && s >= 0 && a.shape(d) != s) ok = false;
    want += (d ? ", " : "") + (s >= 0 ? std::to_string(s) : std::string("n"));
    ++d;
  }
  want += shape.size() == 1 ? ",)" : ")";
  if (!ok) {
    std::string got = "(";
    for (py::ssize_t i = 0; i < a.ndim(); ++i) got += (i ? ", " : "") + std::to_string(a.shape(i));
    throw std::invalid_argument(std::string(name) + " must have shape " + want + ", got " + got + ")");
  }
}

inline int32_t checked_count(py::ssize_t n, const char* name) {
  if (n > std::numeric_limits<int32_t>::max()) throw std::invalid_argument(std::string(name) + " is too long");
  return int32_t(n);
}

// Keeps the (possibly converted) arrays alive for as long as the PolyMeshInput points at them.
struct MeshArrays {
  FloatArray positions;
  IntArray corner_verts, poly_starts, poly_sizes;
  texsynth::PolyMeshInput input;
};

inline MeshArrays mesh_arrays(py::handle positions, py::handle corner_verts, py::handle poly_starts, py::handle poly_sizes) {
  MeshArrays m{float_array(positions, "positions"), int_array(corner_verts, "corner_verts"),
               int_array(poly_starts, "poly_starts"), int_array(poly_sizes, "poly_sizes"), {}};
  require_shape(m.positions, {-1, 3}, "positions");
  require_shape(m.corner_verts, {-1}, "corner_verts");
  require_shape(m.poly_starts, {-1}, "poly_starts");
  require_shape(m.poly_sizes, {m.poly_starts.shape(0)}, "poly_sizes");
  m.input.positions = m.positions.data();
  m.input.num_vertices = checked_count(m.positions.shape(0), "positions");
  m.input.corner_verts = m.corner_verts.data();
  m.input.num_corners = checked_count(m.corner_verts.shape(0), "corner_verts");
  m.input.poly_starts = m.poly_starts.data();
  m.input.poly_sizes = m.poly_sizes.data();
  m.input.num_polys = checked_count(m.poly_starts.shape(0), "poly_starts");
  return m;
}

// Optional (N, 3) float array; an empty array when obj is None.
inline FloatArray optional_vectors(py::handle obj, int32_t n, const char* name) {
  if (obj.is_none()) return FloatArray();
  FloatArray a = float_array(obj, name);
  require_shape(a, {n, 3}, name);
  return a;
}

inline std::vector<int32_t> optional_indices(py::handle obj, const char* name) {
  if (obj.is_none()) return {};
  IntArray a = int_array(obj, name);
  if (a.ndim() != 1) throw std::invalid_argument(std::string(name) + " must be a 1-D sequence of vertex indices");
  return std::vector<int32_t>(a.data(), a.data() + a.size());
}

inline texsynth::Vec3f vec3(py::handle obj, const char* name) {
  FloatArray a = float_array(obj, name);
  if (a.size() != 3) throw std::invalid_argument(std::string(name) + " must have 3 components");
  return {a.data()[0], a.data()[1], a.data()[2]};
}

// A numpy array that takes ownership of `v` (no copy).
template <class T, class Allocator>
py::array_t<T> to_numpy(std::vector<T, Allocator>&& v, std::vector<py::ssize_t> shape) {
  auto* heap = new std::vector<T, Allocator>(std::move(v));
  py::capsule owner(heap, [](void* p) { delete static_cast<std::vector<T, Allocator>*>(p); });
  return py::array_t<T>(shape, heap->data(), owner);
}

// Optional per-vertex scale multiplier (N,) float32; an empty array when obj is None (check None, not data()).
inline FloatArray optional_scale_multiplier(py::handle obj, int32_t num_vertices) {
  if (obj.is_none()) return FloatArray();
  FloatArray a = float_array(obj, "scale_multiplier");
  require_shape(a, {num_vertices}, "scale_multiplier");
  return a;
}

// A borrowed view of an (H, W, C) sample array (row 0 = bottom) as any core struct
// {pixels, width, height, channels}; the caller keeps `px` alive.
template <class View>
View sample_view(const FloatArray& px) {
  if (px.ndim() != 3) throw std::invalid_argument("sample must have shape (height, width, channels)");
  return {px.data(), checked_count(px.shape(1), "sample width"), checked_count(px.shape(0), "sample height"),
          checked_count(px.shape(2), "sample channels")};
}

}  // namespace texsynth_py
