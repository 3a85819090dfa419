// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Small, fast, portable RNG. std::mt19937 + std::uniform_*_distribution are not
// bit-identical across standard libraries, so results would not be reproducible.
#include <cstdint>

namespace texsynth {

// SplitMix64: used to derive independent per-item seeds (e.g. per vertex, per thread-chunk)
// so results never depend on how work is split across threads.
inline uint64_t splitmix64(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// PCG32 (O'Neill), deterministic everywhere.
class Rng {
 public:
  explicit Rng(uint64_t seed, uint64_t stream = 0) {
    state_ = 0;
    inc_ = (splitmix64(stream) << 1u) | 1u;
    next_u32();
    state_ += splitmix64(seed);
    next_u32();
  }
  uint32_t next_u32() {
    uint64_t old = state_;
    state_ = old * 6364136223846793005ull + inc_;
    uint32_t xorshifted = static_cast<uint32_t>(((old >> 18u) ^ old) >> 27u);
    uint32_t rot = static_cast<uint32_t>(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((-rot) & 31));
  }
  // Uniform in [0, 1).
  double uniform() { return (next_u32() >> 8) * (1.0 / 16777216.0); }
  // Uniform integer in [0, n), n > 0 (Lemire's method without rejection bias worth caring about here).
  uint32_t below(uint32_t n) { return static_cast<uint32_t>((static_cast<uint64_t>(next_u32()) * n) >> 32); }

 private:
  uint64_t state_, inc_;
};

}  // namespace texsynth
