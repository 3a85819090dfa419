// SPDX-License-Identifier: GPL-3.0-or-later
// Exemplar index cache file (layout in exemplar_cache.hpp). Reading goes through ByteReader, so
// every problem with a file is a CacheError, as with the other caches.
#include "texsynth/patches/exemplar_cache.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

#include "exemplar_graph.hpp"
#include "texsynth/common/byte_reader.hpp"
#include "texsynth/common/byte_writer.hpp"
#include "texsynth/common/errors.hpp"
#include "texsynth/common/file_bytes.hpp"
#include "texsynth/common/hash.hpp"
#include "texsynth/image/image.hpp"

namespace texsynth {
namespace {

constexpr char kMagic[8] = {'T', 'S', 'E', 'X', 'E', 'M', 'P', 'L'};
constexpr uint64_t kChecksumSeed = 0x74736578656d706cull;

using Clock = std::chrono::steady_clock;

int32_t get_int(ByteReader& r, const char* what, int32_t lo, int32_t hi) {
  const int32_t v = r.get<int32_t>();
  if (v < lo || v > hi) r.corrupt(std::string(what) + " out of range");
  return v;
}

// `count` finite floats.
std::vector<float> get_floats(ByteReader& r, size_t count, const char* what) {
  std::vector<float> v = r.get_vector<float>(count);
  for (float f : v)
    if (!std::isfinite(f)) r.corrupt(std::string(what) + " has NaN or infinite values");
  return v;
}

void put_graph(ByteWriter& w, const PatchIndex& ix) {
  const HnswLinks g = hnsw_links(ix);
  w.put<int32_t>(g.top_level);
  w.put<uint32_t>(g.entry);
  for (size_t i = 0; i < g.labels.size(); ++i) {
    w.put<uint32_t>(g.labels[i]);
    w.put<int32_t>(g.levels[i]);
    size_t at = g.first[i];
    for (int32_t l = 0; l <= g.levels[i]; ++l) {
      const uint32_t n = g.links[at];
      w.put_array(g.links.data() + at, size_t(n) + 1);  // the count, then the ids
      at += size_t(n) + 1;
    }
  }
}

// Reads and checks the link lists (see exemplar_cache.hpp), then restores the graph.
void get_graph(ByteReader& r, PatchIndex& ix, const std::atomic<bool>* cancel) {
  constexpr int kMaxLevel = 32;  // P(level >= 32) = M^-32: never drawn
  const uint32_t n = uint32_t(ix.count());
  const uint32_t max_m = uint32_t(ix.spec.hnsw.M), max_m0 = 2 * max_m;
  HnswLinks g;
  g.top_level = get_int(r, "HNSW top level", 0, kMaxLevel);
  g.entry = r.get<uint32_t>();
  if (g.entry >= n) r.corrupt("HNSW entry point out of range");
  g.labels.resize(n);
  g.levels.resize(n);
  g.first.resize(n);
  g.links.reserve(size_t(n) * (max_m + 2));
  std::vector<uint8_t> seen(n, 0);
  for (uint32_t i = 0; i < n; ++i) {
    if ((i & 4095) == 0) throw_if_cancelled(cancel);
    const uint32_t label = r.get<uint32_t>();
    if (label >= n || seen[label]) r.corrupt("HNSW labels are not a permutation");
    seen[label] = 1;
    g.labels[i] = label;
    g.levels[i] = get_int(r, "HNSW node level", 0, g.top_level);
    g.first[i] = g.links.size();
    for (int32_t l = 0; l <= g.levels[i]; ++l) {
      const uint32_t count = r.get<uint32_t>();
      if (count > (l == 0 ? max_m0 : max_m)) r.corrupt("HNSW link count out of range");
      g.links.push_back(count);
      for (uint32_t k = 0; k < count; ++k) g.links.push_back(r.get<uint32_t>());
    }
  }
  if (g.levels[g.entry] != g.top_level) r.corrupt("HNSW entry point is not on the top level");
  for (uint32_t i = 0; i < n; ++i) {  // every link points to a node that has that level
    size_t at = g.first[i];
    for (int32_t l = 0; l <= g.levels[i]; ++l) {
      const uint32_t count = g.links[at++];
      for (uint32_t k = 0; k < count; ++k, ++at)
        if (g.links[at] >= n || g.levels[g.links[at]] < l) r.corrupt("HNSW link out of range");
    }
  }
  restore_hnsw_graph(ix, g, cancel);
}

void put_index(ByteWriter& w, const PatchIndex& ix) {
  w.put<int32_t>(int32_t(ix.spec.region));
  w.put<int32_t>(ix.spec.patch_size);
  w.put<int32_t>(ix.spec.band_width);
  w.put<int32_t>(ix.spec.dims);
  w.put<int32_t>(ix.spec.hnsw.M);
  w.put<int32_t>(ix.spec.hnsw.ef_construction);
  w.put<int32_t>(ix.spec.hnsw.ef_search);
  w.put<uint64_t>(ix.graph_seed);
  w.put<int32_t>(ix.raw_dims);
  w.put<int32_t>(ix.dims);
  w.put_floats(ix.mean);
  w.put_floats(ix.basis);
  w.put_floats(ix.reduced);
  put_graph(w, ix);
}

PatchIndex get_index(ByteReader& r, const ExemplarAppearance& a, PatchRegion expected, const std::atomic<bool>* cancel) {
  PatchIndex ix;
  ix.spec.region = PatchRegion(get_int(r, "region", 0, 1));
  if (ix.spec.region != expected) r.corrupt("index region mismatch");
  ix.spec.patch_size = get_int(r, "patch size", kMinPatchSize, kMaxPatchSize);
  if (ix.spec.patch_size % kPatchCellSize) r.corrupt("patch size not a multiple of 4");
  ix.spec.band_width = get_int(r, "band width", 0, ix.spec.patch_size / 2);
  if ((expected == PatchRegion::kBand) != (ix.spec.band_width > 0)) r.corrupt("band width inconsistent");
  ix.spec.dims = get_int(r, "patch dims", 1, kMaxPatchDims);
  ix.spec.hnsw.M = get_int(r, "HNSW M", 2, 64);
  ix.spec.hnsw.ef_construction = get_int(r, "HNSW ef_construction", 1, 1000);
  ix.spec.hnsw.ef_search = get_int(r, "HNSW ef_search", 1, 4096);
  ix.graph_seed = r.get<uint64_t>();
  const int32_t need = a.tileable ? ix.spec.patch_size : ix.spec.patch_size + 3;
  if (a.width < need || a.height < need) r.corrupt("sample too small for its patch size");
  ix.sample_width = a.width;
  ix.sample_height = a.height;
  ix.tileable = a.tileable;
  ix.origins_x = a.tileable ? a.width : a.width - ix.spec.patch_size + 1;
  ix.origins_y = a.tileable ? a.height : a.height - ix.spec.patch_size + 1;
  ix.appearance_dims = a.space.dims;
  ix.cells = patch_cells(ix.spec.region, ix.spec.patch_size, ix.spec.band_width);
  ix.raw_dims = get_int(r, "raw dims", 1, 1 << 20);
  if (ix.raw_dims != int(ix.cells.size()) * a.space.dims) r.corrupt("raw dims inconsistent");
  ix.dims = get_int(r, "dims", 1, kMaxPatchDims);
  if (ix.dims != std::min(ix.spec.dims, ix.raw_dims)) r.corrupt("dims inconsistent");
  ix.mean = get_floats(r, size_t(ix.raw_dims), "patch mean");
  ix.basis = get_floats(r, size_t(ix.dims) * size_t(ix.raw_dims), "patch basis");
  ix.reduced = get_floats(r, size_t(ix.count()) * size_t(ix.dims), "reduced vectors");
  get_graph(r, ix, cancel);
  ix.build_columns(a);
  return ix;
}

}  // namespace

uint64_t exemplar_checksum(const void* data, size_t size) { return hash_bytes(data, size, kChecksumSeed); }

std::vector<uint8_t> serialize_exemplar_index(const ExemplarIndex& e) {
  const ExemplarAppearance& a = e.appearance;
  if (a.width != e.width || a.height != e.height || a.space.channels != e.channels ||
      a.values.size() != size_t(a.width) * size_t(a.height) * size_t(a.space.dims) ||
      a.space.basis.size() != size_t(a.space.dims) * size_t(a.space.raw_dims()) ||
      a.space.mean.size() != size_t(a.space.raw_dims()) || (!e.full && !e.band))
    throw std::invalid_argument("serialize_exemplar_index: inconsistent ExemplarIndex");
  ByteWriter w;
  w.bytes.reserve(size_t(1) << 16);
  for (char c : kMagic) w.put<char>(c);
  w.put<uint32_t>(kExemplarFormatVersion);
  w.put<uint64_t>(e.key);
  w.put<int32_t>(e.width);
  w.put<int32_t>(e.height);
  w.put<int32_t>(e.channels);
  w.put<int32_t>(e.patch_size);
  w.put<uint32_t>(e.tileable ? 1 : 0);
  w.put<uint64_t>(e.seed);
  w.put<int32_t>(a.space.dims);
  w.put_floats(a.space.weights);
  w.put_floats(a.space.mean);
  w.put_floats(a.space.basis);
  w.put_floats(a.values);
  w.put<uint32_t>((e.full ? 1u : 0u) | (e.band ? 2u : 0u));
  if (e.full) put_index(w, *e.full);
  if (e.band) put_index(w, *e.band);
  w.put<uint64_t>(exemplar_checksum(w.bytes.data(), w.bytes.size()));
  return std::move(w.bytes);
}

ExemplarIndex deserialize_exemplar_index(const uint8_t* data, size_t size, std::optional<uint64_t> expected_key,
                                         const std::atomic<bool>* cancel, const std::string& what) {
  // Everything but the trailing checksum, once the checksum matched.
  ByteReader r(data, size >= 8 ? size - 8 : 0, what);
  if (!data && size) r.corrupt("null data");
  if (size < sizeof(kMagic) + 4 + 8 + 8) r.corrupt("truncated");
  if (std::memcmp(data, kMagic, sizeof(kMagic)) != 0) r.corrupt("not an exemplar index (bad magic)");
  uint64_t stored_sum;
  std::memcpy(&stored_sum, data + size - 8, 8);
  if (exemplar_checksum(data, size - 8) != stored_sum) r.corrupt("checksum mismatch (truncated or corrupt)");
  r.skip(sizeof(kMagic));
  const uint32_t version = r.get<uint32_t>();
  if (version != kExemplarFormatVersion)
    r.corrupt("format version " + std::to_string(version) + ", expected " + std::to_string(kExemplarFormatVersion));
  ExemplarIndex e;
  e.key = r.get<uint64_t>();
  if (expected_key && *expected_key != e.key) r.corrupt("key mismatch (made for another sample or parameters)");
  e.width = get_int(r, "width", 1, kMaxImageSide);
  e.height = get_int(r, "height", 1, kMaxImageSide);
  if (int64_t(e.width) * e.height > kMaxImagePixels) r.corrupt("sample size out of range");
  e.channels = get_int(r, "channels", 3, 4);
  e.patch_size = get_int(r, "patch size", kMinPatchSize, kMaxPatchSize);
  const uint32_t tileable = r.get<uint32_t>();
  if (tileable > 1) r.corrupt("tileable flag out of range");
  e.tileable = tileable == 1;
  e.seed = r.get<uint64_t>();
  ExemplarAppearance& a = e.appearance;
  a.width = e.width;
  a.height = e.height;
  a.tileable = e.tileable;
  a.space.channels = e.channels;
  a.space.dims = get_int(r, "appearance dims", 1, kAppearanceWindow * kAppearanceWindow * e.channels);
  a.space.weights = get_floats(r, kAppearanceWindow * kAppearanceWindow, "appearance weights");
  a.space.mean = get_floats(r, size_t(a.space.raw_dims()), "appearance mean");
  a.space.basis = get_floats(r, size_t(a.space.dims) * size_t(a.space.raw_dims()), "appearance basis");
  a.values = get_floats(r, size_t(a.width) * size_t(a.height) * size_t(a.space.dims), "appearance values");
  const uint32_t mask = r.get<uint32_t>();
  if (mask < 1 || mask > 3) r.corrupt("index mask out of range");
  const auto t0 = Clock::now();
  if (mask & 1u) e.full = get_index(r, a, PatchRegion::kFull, cancel);
  if (mask & 2u) e.band = get_index(r, a, PatchRegion::kBand, cancel);
  e.stats.seconds_hnsw = std::chrono::duration<double>(Clock::now() - t0).count();
  for (auto* ix : {&e.full, &e.band})
    if (*ix && (*ix)->spec.patch_size != e.patch_size) r.corrupt("patch size inconsistent");
  if (r.left() != 0) r.corrupt("trailing bytes");
  e.stats.index_bytes = int64_t(a.values.size() + a.space.basis.size()) * 4 + (e.full ? e.full->memory_bytes() : 0) +
                        (e.band ? e.band->memory_bytes() : 0);
  return e;
}

void save_exemplar_index(const ExemplarIndex& index, const std::string& path) {
  write_file_atomically(path, serialize_exemplar_index(index), "exemplar index");
}

ExemplarIndex load_exemplar_index(const std::string& path, std::optional<uint64_t> expected_key,
                                  const std::atomic<bool>* cancel) {
  uint64_t file_size = 0;
  const std::vector<uint8_t> bytes = read_file_bytes(path, std::numeric_limits<uint64_t>::max(), file_size);
  if (bytes.size() != file_size) throw CacheError("cache '" + path + "': file changed while reading");
  return deserialize_exemplar_index(bytes.data(), bytes.size(), expected_key, cancel, "cache '" + path + "'");
}

}  // namespace texsynth
