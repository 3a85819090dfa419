// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// On-disk cache of a ParticleAnalysis, so a scene reopened on the same sample and settings skips the
// analysis. Little-endian layout (format kParticleCacheVersion):
//   magic "TSPARTAN" | u32 version | u64 key | i32 width, height, channels | u8 tileable, touching |
//   i32 num_classes, background, min_area | arrays, each a u64 count then its values: centres f32,
//   labels i32, components i32, unwrapped i32 | particles (u64 n, per particle i32 id, class, area,
//   f32 centroid x y, i32 bbox x0 y0 x1 y1, f32 box cx cy angle half_x half_y, i32 boundary, border,
//   u8 complete) | pixel_start i64 | pixel_xy i32 | cooc_start i32 | co-occurrences (u64 n, per entry
//   i32 quadrant, f32 dx dy angle, i32 neighbour, u8 source) | classes (u64 n, per class i32 pixels,
//   particles, complete, f32 colour[4], u8 background has_complete random, f64 density min_distance
//   tolerance) | class pairs (u64 n = num_classes^2, per pair i32 pairs, f64 tolerance margin) |
//   background_fill f32 | i32 merged_small, merged_over_cap, classes_without_complete |
//   f64 stats[7] | u64 checksum (hash_bytes over everything before it).
// The key is the caller's fingerprint of the sample and the settings. Loading checks every length
// against the bytes left before allocating, then every index the particle code follows (labels,
// components, CSR offsets, pixels inside their boxes), so a loaded analysis is safe to use.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "texsynth/particles/analysis.hpp"

namespace texsynth {

constexpr uint32_t kParticleCacheVersion = 5;  // 2: class pairs (issue 30); 3: the touching flag;
                                               // 4: the flag says why (2 = fragments); 5: rims join their
                                               // element (same layout: older analyses are recomputed)

std::vector<uint8_t> serialize_particle_analysis(const ParticleAnalysis& analysis, uint64_t key);
// The trailing checksum of a buffer whose first `size` bytes are `data` (everything before it).
uint64_t particle_cache_checksum(const void* data, size_t size);
// nullopt for another key or another format version; texsynth::CacheError (naming `what`) for
// anything but a complete, consistent buffer (truncated, bad magic, checksum, out-of-range values).
std::optional<ParticleAnalysis> deserialize_particle_analysis(const uint8_t* data, size_t size, uint64_t key,
                                                              const std::string& what = "particle analysis cache");

// Atomic write (temporary file + rename); std::runtime_error on I/O failure.
void save_particle_analysis(const ParticleAnalysis& analysis, const std::string& path, uint64_t key);
// nullopt for a missing file, another key or format version; texsynth::CacheError for a corrupt,
// truncated or unreadable file.
std::optional<ParticleAnalysis> load_particle_analysis(const std::string& path, uint64_t key);

}  // namespace texsynth
