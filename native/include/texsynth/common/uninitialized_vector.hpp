// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// resize() without zero-filling: for buffers that a parallel pass overwrites completely, so the
// pages are first touched (and zeroed by the kernel) by the worker threads, not by a serial memset.
#include <algorithm>
#include <memory>
#include <new>
#include <utility>
#include <vector>

namespace texsynth {

template <class T>
struct UninitializedAllocator : std::allocator<T> {
  template <class U>
  struct rebind {
    using other = UninitializedAllocator<U>;
  };
  UninitializedAllocator() = default;
  template <class U>
  UninitializedAllocator(const UninitializedAllocator<U>&) {}
  template <class U>
  void construct(U* p) noexcept {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};
template <class T>
using UninitializedVector = std::vector<T, UninitializedAllocator<T>>;

// Element-wise comparison with plain vectors (tests compare tables against their definitions).
template <class T>
bool operator==(const UninitializedVector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin());
}
template <class T>
bool operator==(const std::vector<T>& a, const UninitializedVector<T>& b) {
  return b == a;
}
template <class T>
bool operator!=(const UninitializedVector<T>& a, const std::vector<T>& b) {
  return !(a == b);
}
template <class T>
bool operator!=(const std::vector<T>& a, const UninitializedVector<T>& b) {
  return !(b == a);
}

}  // namespace texsynth
