// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Faulting fresh output pages in ahead of time, on a thread that would otherwise wait: the kernel
// zeroes each page at its first touch, so that cost then leaves the critical path.
#include <cstddef>

namespace texsynth {

// Touches one float per 4 KiB page of data[0, count). The stores are kept (volatile); the caller
// overwrites the buffer later anyway. Returns early once stop() is true (asked every 256 pages).
template <class Stop>
void prefault_pages(float* data, size_t count, Stop&& stop) {
  constexpr size_t kPage = 4096 / sizeof(float);
  volatile float* p = data;
  for (size_t i = 0; i < count; i += kPage) {
    if ((i / kPage & 255) == 0 && stop()) return;
    p[i] = 0.f;
  }
}

}  // namespace texsynth
