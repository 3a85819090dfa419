// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Reads plain values back from a cache file's bytes (the counterpart of ByteWriter). Every read is
// checked against the bytes left, and arrays are checked before they are allocated, so a truncated
// or corrupt length can never read out of bounds or ask for more memory than the file holds.
// Problems throw texsynth::CacheError("<what>: ...").
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "texsynth/common/errors.hpp"

namespace texsynth {

class ByteReader {
 public:
  ByteReader(const uint8_t* data, size_t size, std::string what) : data_(data), size_(size), what_(std::move(what)) {}
  template <typename T>
  T get() {
    T value;
    need(sizeof(T));
    std::memcpy(&value, data_ + at_, sizeof(T));
    at_ += sizeof(T);
    return value;
  }
  template <typename T>
  void get_array(T* data, size_t count) {
    if (count > (size_ - at_) / sizeof(T)) corrupt("truncated");
    if (count) std::memcpy(data, data_ + at_, count * sizeof(T));
    at_ += count * sizeof(T);
  }
  // A vector of `count` values; the count is checked against the bytes left first.
  template <typename T>
  std::vector<T> get_vector(uint64_t count) {
    if (count > (size_ - at_) / sizeof(T)) corrupt("truncated (an array longer than the file)");
    std::vector<T> v(static_cast<size_t>(count));
    get_array(v.data(), v.size());
    return v;
  }
  void skip(size_t size) {
    need(size);
    at_ += size;
  }
  size_t at() const { return at_; }
  size_t left() const { return size_ - at_; }
  [[noreturn]] void corrupt(const std::string& why) const { throw CacheError(what_ + ": " + why); }

 private:
  void need(size_t size) {
    if (size > size_ - at_) corrupt("truncated");
  }
  const uint8_t* data_;
  size_t size_;
  std::string what_;
  size_t at_ = 0;
};

}  // namespace texsynth
