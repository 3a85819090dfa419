// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// On-disk cache of a Preprocessed sample. Little-endian binary layout (format version 2):
//   magic "TSPREPRC" | u32 version | params (i32 n, i32 K requested, i32 k, i32 feature_dims,
//   u32 tileable, u64 seed, f64 change_fraction, i32 max_iterations, i32 working_size) | u64 sample_hash |
//   i32 width | i32 height (analysis size) | i32 K | i32 texton_dims | i32 jump_k |
//   i32 sample_width | i32 sample_height | u32 reserved |
//   u16 texton_map[W*H] | f32 textons[K*D] | i32 jump_targets[W*H*k] | u16 jump_weights[W*H*k] |
//   u64 checksum (hash_bytes over everything before it).
// The texton distance table and bucket array are rebuilt on load (derivable). About 26 bytes per
// pixel for k = 4. Written atomically: temporary file in the same directory, then rename.
// Loading validates every field, size and value; any problem throws texsynth::CacheError.
#include <cstdint>
#include <optional>
#include <string>

#include "texsynth/preprocess/preprocessed.hpp"

namespace texsynth {

// 2: working_size and the sample size (version 1 files are recomputed).
constexpr uint32_t kCacheFormatVersion = 2;

void save_preprocessed(const Preprocessed& result, const std::string& path);
Preprocessed load_preprocessed(const std::string& path, std::optional<uint64_t> expected_hash = std::nullopt);

// The trailing checksum of a cache whose first `size` bytes are `data` (everything before the checksum).
uint64_t cache_checksum(const void* data, size_t size);

// 32-bit fingerprint of everything in the params that changes the result (and the format version).
uint32_t params_hash(const PreprocessParams& params);
// Every field params_hash covers, compared in full: the 32-bit hash in the file name can collide, so a
// cache is only used when its stored parameters equal the requested ones.
bool same_params(const PreprocessParams& a, const PreprocessParams& b);

// "<cache_dir>/<sample_hash:016x>-<params_hash:08x>.tscache"
std::string cache_file_path(const std::string& cache_dir, uint64_t sample_hash, const PreprocessParams& params);

enum class CacheState { kFresh, kMissing, kStale };
// Fresh = file exists, validates, and matches the sample hash and every parameter (same_params).
// Never throws CacheError.
CacheState cache_state(const std::string& path, uint64_t sample_hash, const PreprocessParams& params);

}  // namespace texsynth
