// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Fast, portable 64-bit hashing for sample fingerprints and cache checksums (not cryptographic).
#include <cstddef>
#include <cstdint>

namespace texsynth {

// Hashes `size` bytes; identical on every platform (little-endian word reads are assembled bytewise).
uint64_t hash_bytes(const void* data, size_t size, uint64_t seed = 0);

// Mixes one 64-bit value into a running hash.
inline uint64_t hash_combine(uint64_t h, uint64_t value) {
  h ^= value + 0x9E3779B97F4A7C15ull + (h << 6) + (h >> 2);
  h *= 0xBF58476D1CE4E5B9ull;
  return h ^ (h >> 31);
}

}  // namespace texsynth
