// SPDX-License-Identifier: GPL-3.0-or-later
// texsynth_native: thin pybind11 layer over texsynth_core. One bind_<module>.cpp per core module.
// std::invalid_argument -> ValueError (pybind11 default); CacheError and Cancelled get their own types.
#include <pybind11/pybind11.h>

#include <Eigen/Core>

#include "texsynth/common/errors.hpp"

namespace py = pybind11;

void bind_image(py::module_& m);
void bind_preprocess(py::module_& m);
void bind_mesh(py::module_& m);
void bind_field(py::module_& m);
void bind_synth(py::module_& m);
void bind_texton(py::module_& m);
void bind_raycast(py::module_& m);
void bind_curvature(py::module_& m);
void bind_field_mesh(py::module_& m);
void bind_surface(py::module_& m);
void bind_neighbourhood(py::module_& m);
void bind_round(py::module_& m);
void bind_patches(py::module_& m);
void bind_particles(py::module_& m);
void bind_particles_walk(py::module_& m);
void bind_particles_place(py::module_& m);
void bind_particles_decals(py::module_& m);
void bind_build_info(py::module_& m);

PYBIND11_MODULE(texsynth_native, m) {
  m.doc() = "TexSynth native core: sample preprocessing and texture synthesis on meshes.";
  m.attr("__version__") = "0.1.0";

  // Raw, deliberately leaked references: a static py::object would be released after the interpreter
  // is gone (at Blender's exit), and py::exception's call operator is deprecated in pybind11 3.
  static PyObject* cache_error = py::exception<texsynth::CacheError>(m, "CacheError", PyExc_ValueError).release().ptr();
  static PyObject* cancelled = py::exception<texsynth::Cancelled>(m, "Cancelled", PyExc_RuntimeError).release().ptr();
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const texsynth::CacheError& e) {
      PyErr_SetString(cache_error, e.what());
    } catch (const texsynth::Cancelled& e) {
      PyErr_SetString(cancelled, e.what());
    }
  });

  // For the cross-CPU test only (python_tests/blender/test_cross_cpu.py): the cache sizes Eigen reads with cpuid
  // and sizes its matrix-product blocks from, set as another CPU would report them.
  m.def("_set_matrix_cache_sizes", [](std::ptrdiff_t l1, std::ptrdiff_t l2, std::ptrdiff_t l3) {
    if (l1 < 1024 || l2 < l1 || l3 < l2) throw std::invalid_argument("cache sizes must be l1 >= 1024 <= l2 <= l3 bytes");
    Eigen::setCpuCacheSizes(l1, l2, l3);
  }, py::arg("l1"), py::arg("l2"), py::arg("l3"));

  bind_image(m);
  bind_preprocess(m);
  bind_mesh(m);
  bind_field(m);
  bind_synth(m);
  bind_texton(m);
  bind_raycast(m);
  bind_curvature(m);
  bind_field_mesh(m);
  bind_surface(m);
  bind_neighbourhood(m);
  bind_round(m);
  bind_patches(m);
  bind_particles(m);
  bind_particles_walk(m);
  bind_particles_place(m);
  bind_particles_decals(m);
  bind_build_info(m);
}
