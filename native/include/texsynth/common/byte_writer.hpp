// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Appends plain values to a byte buffer, for the cache files (preprocess/cache.cpp,
// patches/exemplar_cache.cpp). Host byte order: little-endian hosts only (x86, ARM).
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

namespace texsynth {

class ByteWriter {
 public:
  std::vector<uint8_t> bytes;
  template <typename T>
  void put(T value) {
    const size_t at = bytes.size();
    bytes.resize(at + sizeof(T));
    std::memcpy(bytes.data() + at, &value, sizeof(T));
  }
  template <typename T>
  void put_array(const T* data, size_t count) {
    const size_t at = bytes.size();
    bytes.resize(at + count * sizeof(T));
    if (count) std::memcpy(bytes.data() + at, data, count * sizeof(T));
  }
  void put_floats(const std::vector<float>& v) { put_array(v.data(), v.size()); }
};

}  // namespace texsynth
