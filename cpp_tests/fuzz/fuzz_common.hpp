// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Helpers shared by the libFuzzer targets: a per-process scratch file, hostile floats, and the
// rule that only the documented exception types may escape (anything else aborts = a finding).
#include <fuzzer/FuzzedDataProvider.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

namespace fuzz {

// A file in /dev/shm (or /tmp) private to this process, rewritten for every input.
inline const std::string& scratch_path(const std::string& extension) {
  static std::string base = [] {
    const char* dir = access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp";
    return std::string(dir) + "/texsynth_fuzz_" + std::to_string(getpid());
  }();
  static std::string path;
  path = base + extension;
  return path;
}

inline void write_file(const std::string& path, const uint8_t* data, size_t size) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), std::streamsize(size));
  if (!out) {
    std::fprintf(stderr, "cannot write scratch file %s\n", path.c_str());
    std::abort();
  }
}

// Mostly ordinary values, often the ones that break geometry code.
inline float hostile_float(FuzzedDataProvider& in, float lo, float hi) {
  static const float kSpecial[] = {0.0f, -0.0f, 1.0f, -1.0f, 1e30f, -1e30f, 1e-30f, 1e-45f,
                                   std::numeric_limits<float>::max(), std::numeric_limits<float>::lowest(),
                                   std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                                   -std::numeric_limits<float>::infinity()};
  const uint8_t pick = in.ConsumeIntegral<uint8_t>();
  if (pick < 40) return kSpecial[pick % (sizeof(kSpecial) / sizeof(kSpecial[0]))];
  return in.ConsumeFloatingPointInRange<float>(lo, hi);
}

inline double hostile_double(FuzzedDataProvider& in, double lo, double hi) {
  const uint8_t pick = in.ConsumeIntegral<uint8_t>();
  if (pick < 40) return double(hostile_float(in, float(lo), float(hi)));
  return in.ConsumeFloatingPointInRange<double>(lo, hi);
}

[[noreturn]] inline void fail(const char* what) {
  std::fprintf(stderr, "fuzz invariant violated: %s\n", what);
  std::abort();
}

inline void require(bool ok, const char* what) {
  if (!ok) fail(what);
}

// Cache targets' input: byte 0 = mode, the rest = file body. Mode bit 0 set: the body gets its right
// trailing checksum (`checksum(data, size)`), so mutations get past it to the validation behind it.
template <class Checksum>
std::vector<uint8_t> cache_body(const uint8_t* data, size_t size, Checksum&& checksum) {
  std::vector<uint8_t> body(data + 1, data + size);
  if (data[0] & 1) {
    const uint64_t sum = checksum(body.data(), body.size());
    const size_t at = body.size();
    body.resize(at + 8);
    std::memcpy(body.data() + at, &sum, 8);
  }
  return body;
}

}  // namespace fuzz
