// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/preprocess/cache.hpp"

#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <unistd.h>

#include "texsynth/common/byte_reader.hpp"
#include "texsynth/common/byte_writer.hpp"
#include "texsynth/common/errors.hpp"
#include "texsynth/common/file_bytes.hpp"
#include "texsynth/common/hash.hpp"
#include "texsynth/image/image.hpp"
#include "texsynth/preprocess/kmeans.hpp"
#include "texsynth/preprocess/preprocess.hpp"
#include "texsynth/preprocess/working_image.hpp"

namespace texsynth {
namespace fs = std::filesystem;

namespace {

constexpr char kMagic[8] = {'T', 'S', 'P', 'R', 'E', 'P', 'R', 'C'};
constexpr uint64_t kChecksumSeed = 0x747363616368ull;
// magic + version + params(4*4 + 4 + 8 + 8 + 4 + 4) + hash + 8*4
constexpr size_t kHeaderSize = 8 + 4 + 44 + 8 + 32;

void put_params(ByteWriter& w, const PreprocessParams& p) {
  w.put<int32_t>(p.neighbourhood);
  w.put<int32_t>(p.num_textons);
  w.put<int32_t>(p.jump_candidates);
  w.put<int32_t>(p.feature_dims);
  w.put<uint32_t>(p.tileable ? 1 : 0);
  w.put<uint64_t>(p.seed);
  w.put<double>(p.kmeans_change_fraction);
  w.put<int32_t>(p.kmeans_max_iterations);
  w.put<int32_t>(p.working_size);
}

size_t payload_size(int64_t pixels, int64_t k, int64_t dims, int64_t jump_k) {
  return size_t(pixels) * 2 + size_t(k * dims) * 4 + size_t(pixels * jump_k) * (4 + 2);
}

}  // namespace

uint64_t cache_checksum(const void* data, size_t size) { return hash_bytes(data, size, kChecksumSeed); }

uint32_t params_hash(const PreprocessParams& params) {
  ByteWriter w;
  w.put<uint32_t>(kCacheFormatVersion);
  put_params(w, params);
  const uint64_t h = hash_bytes(w.bytes.data(), w.bytes.size(), 0x706172616D73ull);
  return uint32_t(h ^ (h >> 32));
}

bool same_params(const PreprocessParams& a, const PreprocessParams& b) {
  // Byte for byte as stored, so a file's parameters compare exactly as written.
  ByteWriter wa, wb;
  put_params(wa, a);
  put_params(wb, b);
  return wa.bytes == wb.bytes;
}

std::string cache_file_path(const std::string& cache_dir, uint64_t sample_hash, const PreprocessParams& params) {
  char name[64];
  std::snprintf(name, sizeof(name), "%016llx-%08x.tscache", static_cast<unsigned long long>(sample_hash),
                params_hash(params));
  return (fs::path(cache_dir) / name).string();
}

void save_preprocessed(const Preprocessed& r, const std::string& path) {
  const int64_t n = int64_t(r.width) * r.height;
  const int k = r.jump_map.k;
  if (r.width <= 0 || r.height <= 0 || r.num_textons < 1 || r.num_textons > kMaxTextons || r.texton_dims < 1 ||
      r.texton_map.size() != size_t(n) || r.textons.size() != size_t(r.num_textons) * size_t(r.texton_dims) ||
      k < 1 || k > kMaxJumpCandidates || r.jump_map.targets.size() != size_t(n) * k ||
      r.jump_map.weights.size() != size_t(n) * k)
    throw std::invalid_argument("save_preprocessed: inconsistent Preprocessed object");
  ByteWriter w;
  w.bytes.reserve(kHeaderSize + payload_size(n, r.num_textons, r.texton_dims, k) + 8);
  w.put_array(kMagic, 8);
  w.put<uint32_t>(kCacheFormatVersion);
  put_params(w, r.params);
  w.put<uint64_t>(r.sample_hash);
  w.put<int32_t>(r.width);
  w.put<int32_t>(r.height);
  w.put<int32_t>(r.num_textons);
  w.put<int32_t>(r.texton_dims);
  w.put<int32_t>(k);
  w.put<int32_t>(r.sample_width > 0 ? r.sample_width : r.width);
  w.put<int32_t>(r.sample_height > 0 ? r.sample_height : r.height);
  w.put<uint32_t>(0);
  for (int32_t t : r.texton_map) w.put<uint16_t>(uint16_t(t));
  w.put_array(r.textons.data(), r.textons.size());
  w.put_array(r.jump_map.targets.data(), r.jump_map.targets.size());
  for (float weight : r.jump_map.weights) w.put<uint16_t>(uint16_t(std::lround(double(weight) * 65535.0)));
  w.put<uint64_t>(cache_checksum(w.bytes.data(), w.bytes.size()));

  write_file_atomically(path, w.bytes, "cache");
}

Preprocessed load_preprocessed(const std::string& path, std::optional<uint64_t> expected_hash) {
  // Header first: nothing is sized from the file until the header has been validated.
  uint64_t file_size = 0;
  const std::vector<uint8_t> head = read_file_bytes(path, kHeaderSize, file_size);
  auto bad = [&](const std::string& what) -> CacheError { return CacheError("cache '" + path + "': " + what); };
  if (file_size < kHeaderSize + 8) throw bad("truncated (" + std::to_string(file_size) + " bytes)");
  ByteReader in(head.data(), head.size(), "cache '" + path + "'");
  char magic[8];
  in.get_array(magic, 8);
  if (std::memcmp(magic, kMagic, 8) != 0) throw bad("not a TexSynth preprocessing cache (bad magic)");
  const uint32_t version = in.get<uint32_t>();
  if (version != kCacheFormatVersion)
    throw bad("format version " + std::to_string(version) + ", expected " + std::to_string(kCacheFormatVersion));

  Preprocessed r;
  PreprocessParams& p = r.params;
  p.neighbourhood = in.get<int32_t>();
  p.num_textons = in.get<int32_t>();
  p.jump_candidates = in.get<int32_t>();
  p.feature_dims = in.get<int32_t>();
  const uint32_t tileable = in.get<uint32_t>();
  p.seed = in.get<uint64_t>();
  p.kmeans_change_fraction = in.get<double>();
  p.kmeans_max_iterations = in.get<int32_t>();
  p.working_size = in.get<int32_t>();
  r.sample_hash = in.get<uint64_t>();
  r.width = in.get<int32_t>();
  r.height = in.get<int32_t>();
  r.num_textons = in.get<int32_t>();
  r.texton_dims = in.get<int32_t>();
  const int32_t jump_k = in.get<int32_t>();
  r.sample_width = in.get<int32_t>();
  r.sample_height = in.get<int32_t>();
  const uint32_t reserved = in.get<uint32_t>();

  // Validate the header before sizing anything from it.
  if (tileable > 1 || reserved != 0) throw bad("corrupt header flags");
  if (r.width <= 0 || r.height <= 0 || r.width > kMaxImageSide || r.height > kMaxImageSide ||
      int64_t(r.width) * r.height > kMaxImagePixels)
    throw bad("invalid image size in header");
  p.tileable = tileable == 1;
  try {
    validate_preprocess(p, r.sample_width, r.sample_height);
  } catch (const std::invalid_argument& e) {
    throw bad(std::string("invalid parameters in header: ") + e.what());
  }
  const Size2 analysed = working_dimensions(r.sample_width, r.sample_height, p.working_size);
  if (analysed.width != r.width || analysed.height != r.height)
    throw bad("analysis size does not follow from the sample size and working size");
  const int64_t n = int64_t(r.width) * r.height;
  if (r.num_textons != resolved_num_textons(p, n)) throw bad("texton count does not match parameters");
  if (jump_k != p.jump_candidates) throw bad("jump map size does not match parameters");
  bool dims_match = false;  // texton_dims follows from n, feature_dims and the (1-4) feature channels
  for (int channels = 1; channels <= 4; ++channels) {
    const int full = p.neighbourhood * p.neighbourhood * channels;
    dims_match |= r.texton_dims == (p.feature_dims > 0 && p.feature_dims < full ? p.feature_dims : full);
  }
  if (!dims_match) throw bad("invalid texton dimension in header");
  const size_t expected = kHeaderSize + payload_size(n, r.num_textons, r.texton_dims, jump_k) + 8;
  if (file_size < expected)
    throw bad("truncated (" + std::to_string(file_size) + " of " + std::to_string(expected) + " bytes)");
  if (file_size > expected) throw bad("unexpected trailing bytes");
  const std::vector<uint8_t> bytes = read_file_bytes(path, expected, file_size);
  if (bytes.size() != expected) throw bad("file changed while reading");
  uint64_t stored_checksum;
  std::memcpy(&stored_checksum, bytes.data() + expected - 8, 8);
  if (cache_checksum(bytes.data(), expected - 8) != stored_checksum) throw bad("checksum mismatch (corrupt)");
  if (expected_hash && *expected_hash != r.sample_hash) throw bad("made from a different sample (hash mismatch)");

  const int k = r.num_textons;
  ByteReader payload(bytes.data(), bytes.size(), "cache '" + path + "'");
  payload.skip(kHeaderSize);
  r.texton_map.resize(size_t(n));
  for (int64_t i = 0; i < n; ++i) {
    const uint16_t t = payload.get<uint16_t>();
    if (t >= k) throw bad("texton label out of range");
    r.texton_map[size_t(i)] = t;
  }
  r.textons.resize(size_t(k) * r.texton_dims);
  payload.get_array(r.textons.data(), r.textons.size());
  for (float v : r.textons)
    if (!std::isfinite(v)) throw bad("non-finite texton value");
  r.jump_map.k = jump_k;
  r.jump_map.targets.resize(size_t(n) * jump_k);
  payload.get_array(r.jump_map.targets.data(), r.jump_map.targets.size());
  r.jump_map.weights.resize(size_t(n) * jump_k);
  for (int64_t p = 0; p < n; ++p) {
    double sum = 0.0;
    for (int i = 0; i < jump_k; ++i) {
      const size_t at = size_t(p) * jump_k + i;
      const int32_t target = r.jump_map.targets[at];
      const uint16_t q = payload.get<uint16_t>();
      if (target < -1 || target >= n || target == p) throw bad("jump target out of range");
      if (target == -1 && q != 0) throw bad("weight on an empty jump slot");
      r.jump_map.weights[at] = float(q / 65535.0);
      sum += q / 65535.0;
    }
    if (sum > 1.0 + 1e-6) throw bad("jump weights of a pixel sum to more than 1");
  }
  r.texton_distances = centre_distance_table(r.textons, k, r.texton_dims);
  build_buckets(r.texton_map, k, r.bucket_start, r.bucket_pixels);
  r.cache_hit = true;
  r.cache_status = "loaded";
  return r;
}

CacheState cache_state(const std::string& path, uint64_t sample_hash, const PreprocessParams& params) {
  std::error_code ec;
  if (!fs::exists(path, ec)) return CacheState::kMissing;
  try {
    const Preprocessed cached = load_preprocessed(path, sample_hash);
    return same_params(cached.params, params) ? CacheState::kFresh : CacheState::kStale;
  } catch (const CacheError&) {
    return CacheState::kStale;
  }
}

}  // namespace texsynth
