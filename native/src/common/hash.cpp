// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/common/hash.hpp"

#include <cstring>

namespace texsynth {
namespace {

constexpr uint64_t kPrime1 = 0x9E3779B185EBCA87ull;
constexpr uint64_t kPrime2 = 0xC2B2AE3D27D4EB4Full;
constexpr uint64_t kPrime3 = 0x165667B19E3779F9ull;

inline uint64_t rotl(uint64_t x, int r) { return (x << r) | (x >> (64 - r)); }

inline uint64_t read_le64(const unsigned char* p) {
  uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}

inline uint64_t lane_round(uint64_t acc, uint64_t input) {
  acc += input * kPrime2;
  acc = rotl(acc, 31);
  return acc * kPrime1;
}

}  // namespace

// xxhash64-style: four independent lanes over 32-byte stripes, then a tail and avalanche.
uint64_t hash_bytes(const void* data, size_t size, uint64_t seed) {
  const auto* p = static_cast<const unsigned char*>(data);
  const unsigned char* end = p + size;
  uint64_t lanes[4] = {seed + kPrime1 + kPrime2, seed + kPrime2, seed, seed - kPrime1};
  while (end - p >= 32) {
    for (int i = 0; i < 4; ++i) lanes[i] = lane_round(lanes[i], read_le64(p + 8 * i));
    p += 32;
  }
  uint64_t h = rotl(lanes[0], 1) + rotl(lanes[1], 7) + rotl(lanes[2], 12) + rotl(lanes[3], 18);
  h += static_cast<uint64_t>(size);
  while (end - p >= 8) {
    h ^= lane_round(0, read_le64(p));
    h = rotl(h, 27) * kPrime1 + kPrime3;
    p += 8;
  }
  while (p < end) {
    h ^= (*p++) * 0x27D4EB2F165667C5ull;
    h = rotl(h, 11) * kPrime1;
  }
  h ^= h >> 33;
  h *= kPrime2;
  h ^= h >> 29;
  h *= kPrime3;
  return h ^ (h >> 32);
}

}  // namespace texsynth
