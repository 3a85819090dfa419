// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The corner-map outputs of synthesize_jumpmap and synthesize_texton as numpy arrays, allocated
// uninitialised (with the GIL held) and written once by the core through `view`: no copies.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>

#include "texsynth/synth/corner_maps.hpp"

namespace texsynth_py {
namespace py = pybind11;

struct CornerMapArrays {
  py::array_t<float> base_uv, blend_uv, blend_weights;
  texsynth::CornerMapsView view;

  // pack_sets: blend_uv as ((S+1)/2, L, 4) RGBA pairs (CornerMapsView::packed_pairs), else (S, L, 2).
  CornerMapArrays(py::ssize_t num_corners, int32_t num_blend_sets, bool pack_sets)
      : base_uv({num_corners, py::ssize_t(2)}),
        blend_uv(pack_sets ? py::array_t<float>({py::ssize_t((num_blend_sets + 1) / 2), num_corners, py::ssize_t(4)})
                           : py::array_t<float>({py::ssize_t(num_blend_sets), num_corners, py::ssize_t(2)})),
        blend_weights({num_corners, py::ssize_t(num_blend_sets)}),
        view{int32_t(num_corners), num_blend_sets, base_uv.mutable_data(), blend_uv.mutable_data(),
             blend_weights.mutable_data()} {
    view.packed_pairs = pack_sets;
  }

  // base_uv, blend_uv (or blend_set_pairs when packed), blend_weights and num_blend_sets.
  void put(py::dict& out) const {
    out["base_uv"] = base_uv;
    out[view.packed_pairs ? "blend_set_pairs" : "blend_uv"] = blend_uv;
    out["blend_weights"] = blend_weights;
    out["num_blend_sets"] = view.num_blend_sets;
  }
};

}  // namespace texsynth_py
