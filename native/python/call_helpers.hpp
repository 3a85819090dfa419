// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Blocks the bindings repeat: the `stats` dicts, and long native calls run without the GIL under a
// cancel= argument (cancel_arg.hpp).
#include <pybind11/pybind11.h>

#include <atomic>
#include <utility>

#include "cancel_arg.hpp"

namespace texsynth_py {
namespace py = pybind11;

namespace detail {
inline void put_items(py::dict&) {}
template <class V, class... Rest>
void put_items(py::dict& d, const char* key, const V& value, const Rest&... rest) {
  d[key] = value;
  put_items(d, rest...);
}
}  // namespace detail

// A dict of key, value pairs in the order given (Python shows insertion order, so it stays the one the
// bindings always had): stats_dict("faces", s.faces, "seconds", s.seconds).
template <class... KeyValues>
py::dict stats_dict(const KeyValues&... key_values) {
  static_assert(sizeof...(KeyValues) % 2 == 0, "stats_dict takes key, value pairs");
  py::dict d;
  detail::put_items(d, key_values...);
  return d;
}

// What a long core call gets from its cancel= argument (a CancelToken or None).
struct CallControl {
  const std::atomic<bool>* cancel = nullptr;
  std::atomic<float>* progress = nullptr;  // null when the call reports no progress
};

// Runs call() with the GIL released, so other Python threads (the add-on's progress bar, a cancel
// button) run meanwhile. call() must not touch Python objects. A C++ exception leaves with the GIL
// held again; module.cpp's translator turns texsynth::Cancelled into texsynth_native.Cancelled.
template <class Call>
auto without_gil(Call&& call) {
  py::gil_scoped_release release;
  return std::forward<Call>(call)();
}

// The same with the token's cancel flag and progress slot: call(CallControl). The token is checked
// (ValueError unless a CancelToken or None) before the GIL is released; with_progress = false leaves
// control.progress null for calls that report none.
template <class Call>
auto cancellable(py::handle token, Call&& call, bool with_progress = true) {
  const CallControl control{cancel_flag(token), with_progress ? progress_slot(token) : nullptr};
  py::gil_scoped_release release;
  return std::forward<Call>(call)(control);
}

}  // namespace texsynth_py
