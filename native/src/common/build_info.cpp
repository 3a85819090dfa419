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

}  // namespace

BuildInfo build_info() {
  // TBB 2020 declares its extern "C" queries inside namespace tbb, oneTBB at global scope.
  using namespace tbb;
  BuildInfo info;
  info.embree_version = dotted(embree_runtime_version());
  info.embree_header_version = RTC_VERSION_STRING;
  info.embree_library = embree_library_file();
  info.tbb_interface_version = TBB_runtime_interface_version();
  info.tbb_header_interface_version = TBB_INTERFACE_VERSION;
#if TBB_VERSION_MAJOR >= 2021
  info.tbb_version = TBB_runtime_version();
#else
  // TBB 2020 reports no version string; its interface version is 11000 + 100 + update (2020.3: 11103).
  if (info.tbb_interface_version / 100 == 111) info.tbb_version = "2020." + std::to_string(info.tbb_interface_version % 100);
#endif
  info.tbb_library = file_holding(reinterpret_cast<const void*>(&TBB_runtime_interface_version));
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
