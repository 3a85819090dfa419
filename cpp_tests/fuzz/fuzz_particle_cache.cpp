// SPDX-License-Identifier: GPL-3.0-or-later
// Particle analysis cache loader: any byte string must load as a consistent ParticleAnalysis, give
// nothing (another key or format version) or throw CacheError; whatever loads must make sprites.
// Input: byte 0 = mode; rest = file body. Mode bit 0 set: the harness appends the correct checksum,
// so mutations get past it and reach the validation behind it. The key is the body's own.
#include <cstring>

#include "fuzz_common.hpp"
#include "texsynth/common/errors.hpp"
#include "texsynth/particles/analysis_cache.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const std::vector<uint8_t> body =
      fuzz::cache_body(data, size, [](const void* d, size_t n) { return texsynth::particle_cache_checksum(d, n); });
  uint64_t key = 0;
  if (body.size() >= 20) std::memcpy(&key, body.data() + 12, 8);  // after magic and version
  std::optional<texsynth::ParticleAnalysis> loaded;
  try {
    loaded = texsynth::deserialize_particle_analysis(body.data(), body.size(), key);
  } catch (const texsynth::CacheError&) {
    return 0;
  }
  if (!loaded) return 0;
  const texsynth::ParticleAnalysis& a = *loaded;
  const size_t n = size_t(a.width) * size_t(a.height);
  fuzz::require(a.labels.size() == n && a.components.size() == n, "per-pixel maps sized");
  fuzz::require(a.pixel_start.size() == a.particles.size() + 1, "pixel offsets sized");
  std::vector<float> sample(n * size_t(a.channels), 0.5f);
  for (size_t id = 0; id < a.particles.size() && id < 4; ++id) {
    const texsynth::ParticleSprite s =
        texsynth::particle_sprite(a, {sample.data(), a.width, a.height, a.channels}, int32_t(id));
    fuzz::require(s.rgba.size() == size_t(s.width) * size_t(s.height) * 4, "sprite sized");
  }
  return 0;
}
