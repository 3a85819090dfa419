// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// texsynth_native.CancelToken: a flag another Python thread raises (token.cancel()) while a native
// call runs with the GIL released; the call then stops soon and raises texsynth_native.Cancelled.
// Calls that report progress store it (0..1) in token.progress, for a progress bar drawn meanwhile.
#include <pybind11/pybind11.h>

#include <atomic>
#include <stdexcept>

namespace texsynth_py {
namespace py = pybind11;

struct CancelToken {
  std::atomic<bool> flag{false};
  std::atomic<float> progress{0};
};

// The flag of `obj` (a CancelToken) or nullptr for None. The caller's argument keeps the token alive.
inline const std::atomic<bool>* cancel_flag(py::handle obj) {
  if (obj.is_none()) return nullptr;
  if (!py::isinstance<CancelToken>(obj))
    throw std::invalid_argument("cancel must be a texsynth_native.CancelToken or None");
  return &obj.cast<CancelToken&>().flag;
}

// The progress slot of `obj` (a CancelToken) or nullptr for None (checked by cancel_flag).
inline std::atomic<float>* progress_slot(py::handle obj) {
  if (obj.is_none() || !py::isinstance<CancelToken>(obj)) return nullptr;
  return &obj.cast<CancelToken&>().progress;
}

inline void bind_cancel_token(py::module_& m) {
  py::class_<CancelToken, std::shared_ptr<CancelToken>>(
      m, "CancelToken", "Pass as cancel= to a long native call; cancel() from another thread stops it (Cancelled).")
      .def(py::init<>())
      .def("cancel", [](CancelToken& t) { t.flag.store(true); }, "Asks the running call to stop.")
      .def_property_readonly("cancelled", [](const CancelToken& t) { return t.flag.load(); })
      .def_property_readonly(
          "progress", [](const CancelToken& t) { return t.progress.load(std::memory_order_relaxed); },
          "0..1 as a running call that reports progress advances (round synthesis); readable from any thread.");
}

}  // namespace texsynth_py
