// SPDX-License-Identifier: GPL-3.0-or-later
#include <pybind11/pybind11.h>

#include "texsynth/common/build_info.hpp"

namespace py = pybind11;

void bind_build_info(py::module_& m) {
  m.def(
      "build_info",
      [] {
        texsynth::BuildInfo info;
        {
          // Creating the Embree device on first use starts its threads.
          py::gil_scoped_release release;
          info = texsynth::build_info();
        }
        py::dict d;
        d["embree_version"] = info.embree_version;
        d["embree_header_version"] = info.embree_header_version;
        d["embree_library"] = info.embree_library;
        d["tbb_version"] = info.tbb_version;
        d["tbb_interface_version"] = info.tbb_interface_version;
        d["tbb_header_interface_version"] = info.tbb_header_interface_version;
        d["tbb_library"] = info.tbb_library;
        d["self_contained"] = info.self_contained;
        d["image_files"] = info.image_files;
        d["compiler"] = info.compiler;
        return d;
      },
      "What this build is and which Embree and TBB answer at run time (versions and the files they were "
      "loaded from).");
}
