// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Disk cache of an ExemplarIndex. Little-endian layout, format kExemplarFormatVersion:
//   magic "TSEXEMPL" | u32 version | u64 key | i32 width, height, channels, patch_size | u32 tileable |
//   u64 seed | appearance (i32 dims, f32 weights[25], mean[raw], basis[dims*raw], values[W*H*dims]) |
//   u32 index mask (1 full, 2 band) | per index: spec (i32 region, patch_size, band_width, dims, M,
//   ef_construction, ef_search), u64 graph_seed, i32 raw_dims, i32 dims, f32 mean[raw],
//   basis[dims*raw], reduced[count*dims], HNSW graph (i32 top level, u32 entry point, per node:
//   u32 label, i32 level, per level 0..level: u32 n, u32 links[n]) | u64 checksum (hash_bytes over
//   everything before it). Every field is checked before the graph is restored (labels a
//   permutation, levels <= 32, link counts <= M (2M at level 0), links to nodes that exist at that
//   level); about 100 bytes per origin and index with M = 16.
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "texsynth/patches/exemplar_index.hpp"

namespace texsynth {

// std::invalid_argument for an index that is not consistent (no HNSW graph, sizes that disagree).
std::vector<uint8_t> serialize_exemplar_index(const ExemplarIndex& index);
// The trailing checksum of a buffer whose first `size` bytes are `data` (everything before it).
uint64_t exemplar_checksum(const void* data, size_t size);
// Throws texsynth::CacheError ("<what>: ...") for anything but a complete, consistent buffer of this
// format version (truncated, corrupt, wrong checksum, NaN/inf values) and, with expected_key, for
// another key; texsynth::Cancelled when *cancel is raised.
ExemplarIndex deserialize_exemplar_index(const uint8_t* data, size_t size,
                                         std::optional<uint64_t> expected_key = std::nullopt,
                                         const std::atomic<bool>* cancel = nullptr,
                                         const std::string& what = "exemplar index buffer");
// Atomic write (temporary file + rename); std::runtime_error on I/O failure.
void save_exemplar_index(const ExemplarIndex& index, const std::string& path);
// texsynth::CacheError for a missing, unreadable or invalid file (as deserialize_exemplar_index).
ExemplarIndex load_exemplar_index(const std::string& path, std::optional<uint64_t> expected_key = std::nullopt,
                                  const std::atomic<bool>* cancel = nullptr);

}  // namespace texsynth
