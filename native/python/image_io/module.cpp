// SPDX-License-Identifier: GPL-3.0-or-later
// texsynth_image_io: image files through OpenImageIO, for the C++ tools' companions and scripts run
// outside Blender. texsynth_native imports it (as a sibling) only when it is handed a file path; packages
// for blender.org builds leave it out, and Blender decodes samples there (docs/dev/blender_org_packages.md).
#include <pybind11/pybind11.h>

namespace py = pybind11;

void bind_image_files(py::module_& m);

PYBIND11_MODULE(texsynth_image_io, m) {
  m.doc() = "TexSynth image files: decoding and writing through OpenImageIO.";
  bind_image_files(m);
}
