// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// What this build is and which libraries answer at run time: the self-contained package must prove that
// its own Embree and TBB are the ones used, even when Blender has loaded other copies.
#include <string>

namespace texsynth {

struct BuildInfo {
  std::string embree_version;          // from the running Embree device (rtcGetDeviceProperty)
  std::string embree_header_version;   // the headers compiled against
  std::string embree_library;          // file that holds the rtc* code called (the module when static)
  // The TBB that this module's own dependencies resolve to (build_info.cpp says why not a plain call).
  std::string tbb_version;             // "2021.8" (TBB_runtime_version), "2020.3" (from the interface version)
  int tbb_interface_version = 0;       // its TBB_runtime_interface_version()
  int tbb_header_interface_version = 0;
  std::string tbb_library;             // the file it was loaded from
  bool self_contained = false;         // TEXSYNTH_SELF_CONTAINED: static Embree/libstdc++, bundled TBB
  bool image_files = false;            // TEXSYNTH_IMAGE_FILES: texsynth_image_io built alongside
  std::string compiler;
};

BuildInfo build_info();

// Embree answering on the process's device, as major*10000 + minor*100 + patch, and the file it lives in.
int embree_runtime_version();
std::string embree_library_file();

// The file (shared library or executable) that holds code at address, as the dynamic loader maps it.
std::string file_holding(const void* address);

}  // namespace texsynth
