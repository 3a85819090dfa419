// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/particles/analysis_cache.hpp"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>

#include "texsynth/common/byte_reader.hpp"
#include "texsynth/common/byte_writer.hpp"
#include "texsynth/common/errors.hpp"
#include "texsynth/common/file_bytes.hpp"
#include "texsynth/common/hash.hpp"

namespace texsynth {
namespace {

constexpr char kMagic[8] = {'T', 'S', 'P', 'A', 'R', 'T', 'A', 'N'};
constexpr uint64_t kChecksumSeed = 0x7473706172746e73ull;
constexpr size_t kHeaderSize = 8 + 4 + 8;
// Bytes per record on disk (see the header's layout).
constexpr size_t kParticleRecord = 3 * 4 + 2 * 4 + 4 * 4 + 5 * 4 + 2 * 4 + 1;
constexpr size_t kCoocRecord = 4 + 3 * 4 + 4 + 1;
constexpr size_t kClassRecord = 3 * 4 + 4 * 4 + 3 + 3 * 8;
constexpr size_t kPairRecord = 4 + 2 * 8;

template <class T>
void put_vector(ByteWriter& w, const std::vector<T>& v) {
  w.put<uint64_t>(v.size());
  w.put_array(v.data(), v.size());
}

// A record count, checked against the bytes left before anything is allocated for it.
uint64_t get_count(ByteReader& r, size_t record_bytes) {
  const uint64_t n = r.get<uint64_t>();
  if (n > r.left() / record_bytes) r.corrupt("truncated (a table longer than the file)");
  return n;
}

bool finite(float x) { return std::isfinite(x); }

template <class T>
void require_finite(const ByteReader& r, const std::vector<T>& v, const char* what) {
  for (T x : v)
    if (!std::isfinite(x)) r.corrupt(std::string(what) + " has NaN or infinite values");
}

// Everything the particle code indexes with, so a loaded analysis cannot lead it out of bounds.
void validate(const ByteReader& r, const ParticleAnalysis& a) {
  auto fail = [&](const std::string& why) { r.corrupt(why); };
  if (a.width < kParticleMinSide || a.height < kParticleMinSide || int64_t(a.width) * a.height > kParticleMaxPixels)
    fail("sample size out of range");
  if (a.channels != 3 && a.channels != 4) fail("channel count out of range");
  if (a.num_classes < 1 || a.num_classes > kParticleMaxLabelClasses) fail("class count out of range");
  if (a.background < 0 || a.background >= a.num_classes) fail("background class out of range");
  if (a.min_area < 0) fail("negative min_area");
  const size_t N = size_t(a.width) * size_t(a.height);
  const int32_t n = int32_t(a.particles.size());
  if (a.particles.size() > N) fail("more particles than pixels");
  if (!a.centres.empty() && a.centres.size() != size_t(a.num_classes) * size_t(a.channels)) fail("centres size");
  if (a.labels.size() != N || a.components.size() != N) fail("label or component map size");
  if (a.unwrapped.size() != (a.tileable ? 2 * N : 0)) fail("unwrapped map size");
  for (int32_t l : a.labels)
    if (l < 0 || l >= a.num_classes) fail("label out of range");
  for (int32_t c : a.components)
    if (c < -1 || c >= n) fail("component id out of range");
  if (a.pixel_start.size() != size_t(n) + 1 || a.pixel_start[0] != 0) fail("pixel offsets size");
  if (a.pixel_start.back() < 0 || uint64_t(a.pixel_start.back()) * 2 != a.pixel_xy.size()) fail("pixel list size");
  if (a.cooc_start.size() != size_t(n) + 1 || a.cooc_start[0] != 0 || size_t(a.cooc_start.back()) != a.cooc.size())
    fail("co-occurrence offsets size");
  const int64_t W = a.width, H = a.height;
  for (int32_t i = 0; i < n; ++i) {
    const Particle& p = a.particles[size_t(i)];
    if (p.id != i || p.class_id < 0 || p.class_id >= a.num_classes || p.area < 1) fail("particle header out of range");
    // Offsets checked one by one from 0 (a subtraction of two forged ones could overflow).
    if (a.pixel_start[size_t(i) + 1] != a.pixel_start[size_t(i)] + p.area) fail("particle pixel count");
    if (a.cooc_start[size_t(i) + 1] < a.cooc_start[size_t(i)]) fail("co-occurrence offsets decrease");
    // Unwrapped boxes stay within a period of the sample (their centroid lies inside it).
    const int64_t lo_x = a.tileable ? -W : 0, hi_x = a.tileable ? 2 * W : W;
    const int64_t lo_y = a.tileable ? -H : 0, hi_y = a.tileable ? 2 * H : H;
    if (p.x0 > p.x1 || p.y0 > p.y1 || p.x0 < lo_x || p.x1 >= hi_x || p.y0 < lo_y || p.y1 >= hi_y)
      fail("particle box out of range");
    if (!finite(p.centroid_x) || !finite(p.centroid_y) || !finite(p.box.cx) || !finite(p.box.cy) ||
        !finite(p.box.angle) || !finite(p.box.half_x) || !finite(p.box.half_y))
      fail("particle geometry has NaN or infinite values");
    for (int64_t k = a.pixel_start[size_t(i)]; k < a.pixel_start[size_t(i) + 1]; ++k) {
      const int32_t x = a.pixel_xy[2 * size_t(k)], y = a.pixel_xy[2 * size_t(k) + 1];
      if (x < p.x0 || x > p.x1 || y < p.y0 || y > p.y1) fail("particle pixel outside its box");
      const size_t at = size_t((y % H + H) % H) * size_t(W) + size_t((x % W + W) % W);
      if (a.components[at] != i) fail("particle pixel not in its component");
    }
  }
  for (const CoOccurrence& c : a.cooc)
    if (c.quadrant < 0 || c.quadrant > 3 || c.neighbour < -1 || c.neighbour >= n || uint8_t(c.source) > 3 ||
        !finite(c.dx) || !finite(c.dy) || !finite(c.angle))
      fail("co-occurrence entry out of range");
  if (a.classes.size() != size_t(a.num_classes)) fail("class table size");
  for (const ParticleClass& c : a.classes) {
    for (float x : c.colour)
      if (!finite(x)) fail("class colour has NaN or infinite values");
    if (!std::isfinite(c.density) || !std::isfinite(c.min_distance) || !std::isfinite(c.tolerance))
      fail("class table has NaN or infinite values");
  }
  if (a.class_pairs.size() != size_t(a.num_classes) * size_t(a.num_classes)) fail("class pair table size");
  for (const ParticleClassPair& p : a.class_pairs)
    if (p.pairs < 0 || !std::isfinite(p.tolerance) || !std::isfinite(p.margin) || p.tolerance < 0 || p.margin < 0)
      fail("class pair table out of range");
  if (a.background_fill.size() != N * size_t(a.channels)) fail("background fill size");
}

}  // namespace

uint64_t particle_cache_checksum(const void* data, size_t size) { return hash_bytes(data, size, kChecksumSeed); }

std::vector<uint8_t> serialize_particle_analysis(const ParticleAnalysis& a, uint64_t key) {
  ByteWriter w;
  w.put_array(kMagic, 8);
  w.put<uint32_t>(kParticleCacheVersion);
  w.put<uint64_t>(key);
  w.put<int32_t>(a.width), w.put<int32_t>(a.height), w.put<int32_t>(a.channels);
  w.put<uint8_t>(a.tileable);
  w.put<uint8_t>(a.touching ? (a.touching_fragments ? 2 : 1) : 0);
  w.put<int32_t>(a.num_classes), w.put<int32_t>(a.background), w.put<int32_t>(a.min_area);
  put_vector(w, a.centres);
  put_vector(w, a.labels);
  put_vector(w, a.components);
  put_vector(w, a.unwrapped);
  w.put<uint64_t>(a.particles.size());
  for (const Particle& p : a.particles) {
    w.put<int32_t>(p.id), w.put<int32_t>(p.class_id), w.put<int32_t>(p.area);
    w.put<float>(p.centroid_x), w.put<float>(p.centroid_y);
    w.put<int32_t>(p.x0), w.put<int32_t>(p.y0), w.put<int32_t>(p.x1), w.put<int32_t>(p.y1);
    w.put<float>(p.box.cx), w.put<float>(p.box.cy), w.put<float>(p.box.angle);
    w.put<float>(p.box.half_x), w.put<float>(p.box.half_y);
    w.put<int32_t>(p.boundary_pixels), w.put<int32_t>(p.border_pixels);
    w.put<uint8_t>(p.complete);
  }
  put_vector(w, a.pixel_start);
  put_vector(w, a.pixel_xy);
  put_vector(w, a.cooc_start);
  w.put<uint64_t>(a.cooc.size());
  for (const CoOccurrence& c : a.cooc) {
    w.put<int32_t>(c.quadrant);
    w.put<float>(c.dx), w.put<float>(c.dy), w.put<float>(c.angle);
    w.put<int32_t>(c.neighbour);
    w.put<uint8_t>(uint8_t(c.source));
  }
  w.put<uint64_t>(a.classes.size());
  for (const ParticleClass& c : a.classes) {
    w.put<int32_t>(c.pixels), w.put<int32_t>(c.particles), w.put<int32_t>(c.complete);
    w.put_array(c.colour.data(), c.colour.size());
    w.put<uint8_t>(c.background), w.put<uint8_t>(c.has_complete), w.put<uint8_t>(c.random);
    w.put<double>(c.density), w.put<double>(c.min_distance), w.put<double>(c.tolerance);
  }
  w.put<uint64_t>(a.class_pairs.size());
  for (const ParticleClassPair& p : a.class_pairs)
    w.put<int32_t>(p.pairs), w.put<double>(p.tolerance), w.put<double>(p.margin);
  put_vector(w, a.background_fill);
  w.put<int32_t>(a.merged_small), w.put<int32_t>(a.merged_over_cap), w.put<int32_t>(a.classes_without_complete);
  const ParticleAnalysisStats& s = a.stats;
  for (double x : {s.seconds_blur, s.seconds_kmeans, s.seconds_components, s.seconds_geometry, s.seconds_cooccurrence,
                   s.seconds_background, s.seconds_total})
    w.put<double>(x);
  w.put<uint64_t>(particle_cache_checksum(w.bytes.data(), w.bytes.size()));
  return std::move(w.bytes);
}

std::optional<ParticleAnalysis> deserialize_particle_analysis(const uint8_t* data, size_t size, uint64_t key,
                                                              const std::string& what) {
  ByteReader head(data, size, what);
  if (size < kHeaderSize + 8) head.corrupt("truncated (" + std::to_string(size) + " bytes)");
  char magic[8];
  head.get_array(magic, 8);
  if (std::memcmp(magic, kMagic, 8) != 0) head.corrupt("not a TexSynth particle analysis cache (bad magic)");
  if (head.get<uint32_t>() != kParticleCacheVersion) return std::nullopt;  // another format: recompute
  uint64_t stored;
  std::memcpy(&stored, data + size - 8, 8);
  if (particle_cache_checksum(data, size - 8) != stored) head.corrupt("checksum mismatch (corrupt or truncated)");
  if (head.get<uint64_t>() != key) return std::nullopt;

  ByteReader r(data, size - 8, what);
  r.skip(kHeaderSize);
  ParticleAnalysis a;
  a.width = r.get<int32_t>(), a.height = r.get<int32_t>(), a.channels = r.get<int32_t>();
  const uint8_t tileable = r.get<uint8_t>();
  if (tileable > 1) r.corrupt("corrupt tileable flag");
  a.tileable = tileable == 1;
  const uint8_t touching = r.get<uint8_t>();
  if (touching > 2) r.corrupt("corrupt touching flag");
  a.touching = touching >= 1, a.touching_fragments = touching == 2;
  a.num_classes = r.get<int32_t>(), a.background = r.get<int32_t>(), a.min_area = r.get<int32_t>();
  a.centres = r.get_vector<float>(r.get<uint64_t>());
  a.labels = r.get_vector<int32_t>(r.get<uint64_t>());
  a.components = r.get_vector<int32_t>(r.get<uint64_t>());
  a.unwrapped = r.get_vector<int32_t>(r.get<uint64_t>());
  a.particles.resize(size_t(get_count(r, kParticleRecord)));
  for (Particle& p : a.particles) {
    p.id = r.get<int32_t>(), p.class_id = r.get<int32_t>(), p.area = r.get<int32_t>();
    p.centroid_x = r.get<float>(), p.centroid_y = r.get<float>();
    p.x0 = r.get<int32_t>(), p.y0 = r.get<int32_t>(), p.x1 = r.get<int32_t>(), p.y1 = r.get<int32_t>();
    p.box.cx = r.get<float>(), p.box.cy = r.get<float>(), p.box.angle = r.get<float>();
    p.box.half_x = r.get<float>(), p.box.half_y = r.get<float>();
    p.boundary_pixels = r.get<int32_t>(), p.border_pixels = r.get<int32_t>();
    const uint8_t complete = r.get<uint8_t>();
    if (complete > 1) r.corrupt("corrupt completeness flag");
    p.complete = complete == 1;
  }
  a.pixel_start = r.get_vector<int64_t>(r.get<uint64_t>());
  a.pixel_xy = r.get_vector<int32_t>(r.get<uint64_t>());
  a.cooc_start = r.get_vector<int32_t>(r.get<uint64_t>());
  a.cooc.resize(size_t(get_count(r, kCoocRecord)));
  for (CoOccurrence& c : a.cooc) {
    c.quadrant = r.get<int32_t>();
    c.dx = r.get<float>(), c.dy = r.get<float>(), c.angle = r.get<float>();
    c.neighbour = r.get<int32_t>();
    c.source = EntrySource(r.get<uint8_t>());
  }
  a.classes.resize(size_t(get_count(r, kClassRecord)));
  for (ParticleClass& c : a.classes) {
    c.pixels = r.get<int32_t>(), c.particles = r.get<int32_t>(), c.complete = r.get<int32_t>();
    r.get_array(c.colour.data(), c.colour.size());
    const uint8_t background = r.get<uint8_t>(), has_complete = r.get<uint8_t>(), random = r.get<uint8_t>();
    if (background > 1 || has_complete > 1 || random > 1) r.corrupt("corrupt class flags");
    c.background = background, c.has_complete = has_complete, c.random = random;
    c.density = r.get<double>(), c.min_distance = r.get<double>(), c.tolerance = r.get<double>();
  }
  a.class_pairs.resize(size_t(get_count(r, kPairRecord)));
  for (ParticleClassPair& p : a.class_pairs)
    p.pairs = r.get<int32_t>(), p.tolerance = r.get<double>(), p.margin = r.get<double>();
  a.background_fill = r.get_vector<float>(r.get<uint64_t>());
  a.merged_small = r.get<int32_t>(), a.merged_over_cap = r.get<int32_t>();
  a.classes_without_complete = r.get<int32_t>();
  ParticleAnalysisStats& s = a.stats;
  for (double* x : {&s.seconds_blur, &s.seconds_kmeans, &s.seconds_components, &s.seconds_geometry,
                    &s.seconds_cooccurrence, &s.seconds_background, &s.seconds_total})
    *x = r.get<double>();
  if (r.left() != 0) r.corrupt("unexpected trailing bytes");
  require_finite(r, a.centres, "k-means centres");
  require_finite(r, a.background_fill, "background fill");
  validate(r, a);
  return a;
}

void save_particle_analysis(const ParticleAnalysis& analysis, const std::string& path, uint64_t key) {
  write_file_atomically(path, serialize_particle_analysis(analysis, key), "particle analysis cache");
}

std::optional<ParticleAnalysis> load_particle_analysis(const std::string& path, uint64_t key) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return std::nullopt;
  uint64_t file_size = 0;
  const std::vector<uint8_t> bytes = read_file_bytes(path, std::numeric_limits<uint64_t>::max(), file_size);
  if (bytes.size() != file_size) throw CacheError("cache '" + path + "': file changed while reading");
  return deserialize_particle_analysis(bytes.data(), bytes.size(), key, "cache '" + path + "'");
}

}  // namespace texsynth
