// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/common/build_info.hpp"

#include <dlfcn.h>

// oneTBB (2021+) declares the runtime queries in tbb/version.h, TBB 2020 in tbb/tbb_stddef.h.
#if __has_include(<tbb/version.h>)
#include <tbb/version.h>
#else
#include <tbb/tbb_stddef.h>
#endif

#include "../raycast/embree_compat.hpp"

#include <climits>
#include <cstdlib>
#include <memory>

namespace texsynth {

std::string file_holding(const void* address) {
  Dl_info info{};
  if (!dladdr(address, &info) || !info.dli_fname) return "";
  // The loader's name may be relative or a symlink (libtbb.so.12): the real file says which build.
  std::unique_ptr<char, decltype(&std::free)> real(realpath(info.dli_fname, nullptr), &std::free);
  return real ? std::string(real.get()) : std::string(info.dli_fname);
}

namespace {

std::string dotted(int packed) {
  return std::to_string(packed / 10000) + "." + std::to_string(packed / 100 % 100) + "." + std::to_string(packed % 100);
}

// The TBB this module's own NEEDED entries lead to, asked through a handle on the module: dlsym on a
// handle searches that object's dependencies, not the process's global scope. A plain call would not do:
// TBB_runtime_interface_version is extern "C" in every TBB, so in a Blender that loaded its own oneTBB
// first, the call binds to Blender's copy while TexSynth's parallel loops (C++ symbols of another name)
// run on the bundled one.
void ask_linked_tbb(BuildInfo& info) {
  Dl_info self{};
  void* handle = nullptr;
  if (dladdr(reinterpret_cast<const void*>(&build_info), &self) && self.dli_fname)
    handle = dlopen(self.dli_fname, RTLD_LAZY | RTLD_NOLOAD);
  if (!handle) handle = dlopen(nullptr, RTLD_LAZY);  // linked into an executable
  auto interface_version = reinterpret_cast<int (*)()>(dlsym(handle, "TBB_runtime_interface_version"));
  auto runtime_version = reinterpret_cast<const char* (*)()>(dlsym(handle, "TBB_runtime_version"));  // oneTBB only
  if (interface_version) {
    info.tbb_interface_version = interface_version();
    info.tbb_library = file_holding(reinterpret_cast<const void*>(interface_version));
  }
  if (runtime_version) {
    info.tbb_version = runtime_version();
  } else if (info.tbb_interface_version / 100 == 111) {
    // TBB 2020 has no version string; its interface version is 11100 + update (2020.3: 11103).
    info.tbb_version = "2020." + std::to_string(info.tbb_interface_version % 100);
  }
  if (handle) dlclose(handle);
}

}  // namespace

BuildInfo build_info() {
  BuildInfo info;
  info.embree_version = dotted(embree_runtime_version());
  info.embree_header_version = RTC_VERSION_STRING;
  info.embree_library = embree_library_file();
  info.tbb_header_interface_version = TBB_INTERFACE_VERSION;
  ask_linked_tbb(info);
#ifdef TEXSYNTH_SELF_CONTAINED_BUILD
  info.self_contained = true;
#endif
#ifdef TEXSYNTH_IMAGE_FILES_BUILD
  info.image_files = true;
#endif
#if defined(__clang__)
  info.compiler = "clang " __clang_version__;
#elif defined(__GNUC__)
  info.compiler = "gcc " __VERSION__;
#endif
  return info;
}

}  // namespace texsynth
