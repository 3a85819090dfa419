// SPDX-License-Identifier: GPL-3.0-or-later
// Exemplar analysis for vector-field patches (patches/exemplar_index.hpp): exact hits, HNSW recall
// against the exhaustive search, thread-count independence, the band feature, refusals,
// serialization and cancel.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <atomic>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "synthetic_texture.hpp"
#include "temp_dir.hpp"
#include "texsynth/common/errors.hpp"
#include "texsynth/common/rng.hpp"
#include "texsynth/patches/exemplar_cache.hpp"
#include "texsynth/patches/exemplar_index.hpp"

namespace {

using texsynth::ExemplarIndex;
using texsynth::ExemplarParams;
using texsynth::ExemplarSample;
using texsynth::PatchIndex;
using texsynth::PatchMatch;

struct Pixels {
  int width, height, channels;
  std::vector<float> v;
  ExemplarSample view() const { return {v.data(), width, height, channels}; }
  float* at(int x, int y) { return v.data() + (size_t(y) * width + x) * channels; }
};

// Value noise at two scales plus per-pixel noise: every patch is distinct, few are near-duplicates.
Pixels noise_sample(int w, int h, int channels = 3, uint64_t seed = 5) {
  Pixels p{w, h, channels, std::vector<float>(size_t(w) * h * channels)};
  texsynth::Rng rng(seed);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < channels; ++c)
        p.at(x, y)[c] = 0.5f * texsynth_test::value_noise(float(x), float(y), 6.f, seed + c) +
                        0.3f * texsynth_test::value_noise(float(x), float(y), 2.f, seed + 10 + c) +
                        0.2f * float(rng.uniform());
  return p;
}

ExemplarParams small_params(int patch = 16) {
  ExemplarParams p;
  p.patch_size = patch;
  p.seed = 3;
  return p;
}

float dist2(const float* a, const float* b, int n) {
  float s = 0;
  for (int i = 0; i < n; ++i) s += (a[i] - b[i]) * (a[i] - b[i]);
  return s;
}

// Raw patch vector of origin (ox, oy) computed from pixels through the public projection (the
// synthesizer's path); the origin must leave the 5x5 windows inside the sample.
std::vector<float> raw_from_pixels(const Pixels& s, const texsynth::AppearanceSpace& space, const PatchIndex& ix,
                                   int ox, int oy) {
  std::vector<float> raw(size_t(ix.raw_dims)), window(size_t(space.raw_dims()));
  for (size_t c = 0; c < ix.cells.size(); ++c) {
    const int cx = ox + ix.cells[c][0], cy = oy + ix.cells[c][1];
    for (int dy = 0; dy < 5; ++dy)
      for (int dx = 0; dx < 5; ++dx)
        for (int ch = 0; ch < s.channels; ++ch)
          window[size_t((dy * 5 + dx) * s.channels + ch)] =
              s.v[(size_t(cy + dy - 2) * s.width + (cx + dx - 2)) * s.channels + ch];
    space.project(window.data(), raw.data() + c * size_t(space.dims));
  }
  return raw;
}

TEST(PatchesExemplar, ExactFeatureFindsItsOrigin) {
  const Pixels s = noise_sample(60, 52);
  const ExemplarIndex e = texsynth::build_exemplar_index(s.view(), small_params());
  ASSERT_TRUE(e.full.has_value());
  const PatchIndex& ix = *e.full;
  EXPECT_EQ(ix.origins_x, 60 - 16 + 1);
  EXPECT_EQ(ix.origins_y, 52 - 16 + 1);
  EXPECT_EQ(ix.raw_dims, 16 * 5);  // 4x4 cells x 5 appearance dims
  EXPECT_EQ(ix.dims, 30);
  std::vector<float> raw(size_t(ix.raw_dims)), reduced(size_t(ix.dims));
  for (const auto& o : {std::array<int, 2>{0, 0}, {44, 36}, {17, 5}, {3, 29}, {30, 12}}) {
    const int32_t id = o[1] * ix.origins_x + o[0];
    for (const auto& m : {ix.search(ix.reduced_at(id), 4), ix.search_exact(ix.reduced_at(id), 4)}) {
      ASSERT_EQ(m.size(), 4u);
      EXPECT_EQ(m[0].x, o[0]);
      EXPECT_EQ(m[0].y, o[1]);
      EXPECT_LT(m[0].distance2, 1e-8f);
      EXPECT_GT(m[1].distance2, 1e-3f);  // no near-duplicate patches in noise
      EXPECT_LE(m[1].distance2, m[2].distance2);
    }
    // raw -> projected = the stored reduced vector.
    ix.raw_feature(e.appearance, id, raw.data());
    ix.project(raw.data(), nullptr, reduced.data());
    EXPECT_LT(dist2(reduced.data(), ix.reduced_at(id), ix.dims), 1e-8f);
  }
  // The synthesizer's path: colours -> AppearanceSpace::project -> PatchIndex::project -> search.
  const auto raw_px = raw_from_pixels(s, e.appearance.space, ix, 20, 14);
  ix.project(raw_px.data(), nullptr, reduced.data());
  const auto m = ix.search(reduced.data(), 1);
  EXPECT_EQ(m[0].x, 20);
  EXPECT_EQ(m[0].y, 14);
  EXPECT_LT(m[0].distance2, 1e-6f);
}

TEST(PatchesExemplar, TileableOriginsWrap) {
  const Pixels s = noise_sample(40, 36);
  ExemplarParams p = small_params();
  p.tileable = true;
  const ExemplarIndex e = texsynth::build_exemplar_index(s.view(), p);
  const PatchIndex& ix = *e.full;
  EXPECT_EQ(ix.count(), 40 * 36);
  const int32_t id = 33 * ix.origins_x + 38;  // window wraps in x and y
  std::vector<float> raw(size_t(ix.raw_dims));
  ix.raw_feature(e.appearance, id, raw.data());
  const int d = e.appearance.space.dims;
  // Cell (1, 1) sits at (38 + 6, 33 + 6) = (4, 3) after wrapping.
  EXPECT_EQ(std::memcmp(raw.data() + (1 * 4 + 1) * d, e.appearance.at(4, 3), sizeof(float) * d), 0);
  const auto m = ix.search_exact(ix.reduced_at(id), 1);
  EXPECT_EQ(m[0].x, 38);
  EXPECT_EQ(m[0].y, 33);
}

TEST(PatchesExemplar, HnswRecallAgainstExhaustive) {
  const Pixels s = noise_sample(64, 64, 3, 9);
  ExemplarParams p = small_params();
  p.tileable = true;
  const ExemplarIndex e = texsynth::build_exemplar_index(s.view(), p);
  const PatchIndex& ix = *e.full;
  ASSERT_EQ(ix.count(), 4096);
  // Queries near the data but not on it: an origin's vector plus noise, and the mean of two.
  texsynth::Rng rng(17);
  const int n = 150;
  std::vector<float> queries(size_t(2 * n) * ix.dims);
  for (int q = 0; q < n; ++q) {
    const float* a = ix.reduced_at(int32_t(rng.below(4096)));
    const float* b = ix.reduced_at(int32_t(rng.below(4096)));
    for (int d = 0; d < ix.dims; ++d) {
      queries[size_t(q) * ix.dims + d] = a[d] + 0.2f * float(rng.uniform() - 0.5);
      queries[size_t(n + q) * ix.dims + d] = 0.5f * (a[d] + b[d]);
    }
  }
  const auto batch = ix.search_batch(queries.data(), 2 * n, 16, true);
  int hits1 = 0, hits16 = 0;
  for (int q = 0; q < 2 * n; ++q) {
    const float* v = queries.data() + size_t(q) * ix.dims;
    const auto exact = ix.search_exact(v, 16);
    const auto approx = ix.search(v, 16);
    ASSERT_EQ(exact.size(), 16u);
    ASSERT_EQ(approx.size(), 16u);
    for (int i = 0; i < 16; ++i) {  // batched GEMM path = single exact search
      EXPECT_EQ(batch[size_t(q) * 16 + i].x, exact[size_t(i)].x);
      EXPECT_EQ(batch[size_t(q) * 16 + i].y, exact[size_t(i)].y);
      EXPECT_NEAR(batch[size_t(q) * 16 + i].distance2, exact[size_t(i)].distance2, 1e-4f);
    }
    for (int i = 1; i < 16; ++i) EXPECT_LE(exact[size_t(i - 1)].distance2, exact[size_t(i)].distance2);
    hits1 += approx[0].x == exact[0].x && approx[0].y == exact[0].y;
    for (const auto& x : exact)
      for (const auto& a : approx) hits16 += a.x == x.x && a.y == x.y;
    EXPECT_NEAR(approx[0].distance2, dist2(v, ix.reduced_at(approx[0].y * ix.origins_x + approx[0].x), ix.dims), 1e-3f);
  }
  EXPECT_GE(double(hits1) / (2 * n), 0.95);
  EXPECT_GE(double(hits16) / (2 * n * 16), 0.9);
}

TEST(PatchesExemplar, SameResultsWithOneAndTwoThreads) {
  const Pixels s = noise_sample(70, 58);
  ExemplarParams p = small_params();
  p.band_index = true;
  std::vector<uint8_t> bytes[2];
  std::vector<PatchMatch> found[2];
  for (int t = 0; t < 2; ++t) {
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, size_t(t + 1));
    const ExemplarIndex e = texsynth::build_exemplar_index(s.view(), p);
    bytes[t] = texsynth::serialize_exemplar_index(e);
    texsynth::Rng rng(4);
    std::vector<float> q(size_t(e.full->dims));
    for (int i = 0; i < 60; ++i) {
      for (auto& v : q) v = float(rng.uniform() * 2 - 1);
      for (const PatchIndex* ix : {&*e.full, &*e.band}) {
        const auto m = ix->search(q.data(), 8);
        found[t].insert(found[t].end(), m.begin(), m.end());
      }
    }
  }
  ASSERT_EQ(bytes[0].size(), bytes[1].size());
  EXPECT_TRUE(bytes[0] == bytes[1]);  // appearance, PCA and reduced vectors bit-identical
  ASSERT_EQ(found[0].size(), found[1].size());
  for (size_t i = 0; i < found[0].size(); ++i) {
    EXPECT_EQ(found[0][i].x, found[1][i].x);
    EXPECT_EQ(found[0][i].y, found[1][i].y);
    EXPECT_EQ(found[0][i].distance2, found[1][i].distance2);
  }
}

TEST(PatchesExemplar, BandFeatureIgnoresTheInterior) {
  Pixels s = noise_sample(60, 60);
  ExemplarParams p = small_params(32);
  p.band_index = true;
  const ExemplarIndex e = texsynth::build_exemplar_index(s.view(), p);
  const PatchIndex& full = *e.full;
  const PatchIndex& band = *e.band;
  EXPECT_EQ(band.cells.size(), 28u);  // 8x8 cells minus the 6x6 interior
  EXPECT_EQ(band.raw_dims, 28 * 5);
  for (const auto& c : band.cells)
    EXPECT_TRUE(c[0] < 4 || c[0] >= 28 || c[1] < 4 || c[1] >= 28) << c[0] << "," << c[1];
  // Repaint the interior of patch (10, 12): pixels 5..26 from the origin reach no band cell's
  // 5x5 window (band cells sit at offsets 2 and 30, windows +-2).
  const int ox = 10, oy = 12;
  Pixels repainted = s;
  texsynth::Rng rng(8);
  for (int y = oy + 5; y <= oy + 26; ++y)
    for (int x = ox + 5; x <= ox + 26; ++x)
      for (int c = 0; c < 3; ++c) repainted.at(x, y)[c] = float(rng.uniform());
  const int32_t id = oy * full.origins_x + ox;
  std::vector<float> q(size_t(30));
  const auto band_raw = raw_from_pixels(repainted, e.appearance.space, band, ox, oy);
  band.project(band_raw.data(), nullptr, q.data());
  EXPECT_LT(dist2(q.data(), band.reduced_at(id), band.dims), 1e-6f);
  const auto bm = band.search_exact(q.data(), 1);
  EXPECT_EQ(bm[0].x, ox);
  EXPECT_EQ(bm[0].y, oy);
  // The full feature does see the repainted interior.
  const auto full_raw = raw_from_pixels(repainted, e.appearance.space, full, ox, oy);
  full.project(full_raw.data(), nullptr, q.data());
  EXPECT_GT(dist2(q.data(), full.reduced_at(id), full.dims), 1.0f);
}

TEST(PatchesExemplar, MaskedCellsProjectAsTheMean) {
  const Pixels s = noise_sample(48, 48);
  const ExemplarIndex e = texsynth::build_exemplar_index(s.view(), small_params());
  const PatchIndex& ix = *e.full;
  std::vector<float> raw(size_t(ix.raw_dims)), with_mean(raw.size()), a(30), b(30), c(30);
  ix.raw_feature(e.appearance, 100, raw.data());
  std::vector<uint8_t> valid(ix.cells.size(), 1);
  with_mean = raw;
  for (size_t cell : {size_t(0), size_t(5), size_t(15)}) {
    valid[cell] = 0;
    for (int d = 0; d < ix.appearance_dims; ++d) {
      raw[cell * 5 + size_t(d)] = std::numeric_limits<float>::quiet_NaN();  // never read
      with_mean[cell * 5 + size_t(d)] = ix.mean[cell * 5 + size_t(d)];
    }
  }
  ix.project(raw.data(), valid.data(), a.data());
  ix.project(with_mean.data(), nullptr, b.data());
  for (int d = 0; d < ix.dims; ++d) {
    ASSERT_TRUE(std::isfinite(a[size_t(d)]));
    EXPECT_NEAR(a[size_t(d)], b[size_t(d)], 1e-5f);
  }
  std::fill(valid.begin(), valid.end(), 0);
  ix.project(raw.data(), valid.data(), c.data());
  for (float v : c) EXPECT_EQ(v, 0.f);  // nothing known: the mean patch
}

TEST(PatchesExemplar, FitPatchSize) {
  EXPECT_EQ(texsynth::fit_patch_size(96, 96, 32), 32);
  EXPECT_EQ(texsynth::fit_patch_size(35, 40, 32), 32);
  EXPECT_EQ(texsynth::fit_patch_size(34, 100, 32), 16);  // 34 / 2 = 17 -> 16
  EXPECT_EQ(texsynth::fit_patch_size(20, 20, 32), 8);
  EXPECT_EQ(texsynth::fit_patch_size(16, 300, 32), 8);
  EXPECT_EQ(texsynth::fit_patch_size(32, 32, 32, true), 32);
  EXPECT_EQ(texsynth::fit_patch_size(30, 32, 32, true), 12);
  EXPECT_THROW(texsynth::fit_patch_size(15, 100, 32), std::invalid_argument);
  EXPECT_THROW(texsynth::fit_patch_size(96, 96, 30), std::invalid_argument);
  EXPECT_THROW(texsynth::fit_patch_size(96, 96, 4), std::invalid_argument);
  EXPECT_THROW(texsynth::fit_patch_size(960, 960, 68), std::invalid_argument);
}

void expect_refused(const ExemplarSample& s, const ExemplarParams& p, const std::string& words) {
  try {
    texsynth::build_exemplar_index(s, p);
    ADD_FAILURE() << "accepted; expected a refusal mentioning '" << words << "'";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
  }
}

TEST(PatchesExemplar, RefusesBadInputs) {
  const Pixels s = noise_sample(40, 40);
  const ExemplarParams ok = small_params();
  ExemplarSample v = s.view();
  v.pixels = nullptr;
  expect_refused(v, ok, "null");
  v = s.view();
  v.channels = 2;
  expect_refused(v, ok, "3 or 4 channels");
  v.channels = 5;
  expect_refused(v, ok, "3 or 4 channels");
  for (int patch : {30, 4, 0, 68}) {
    ExemplarParams p = ok;
    p.patch_size = patch;
    expect_refused(s.view(), p, "multiple of 4");
  }
  {
    ExemplarParams p = ok;
    p.patch_size = 40;  // 40 + 3 > 40
    expect_refused(s.view(), p, "too small");
    p.tileable = true;  // a tileable sample only needs the window itself
    EXPECT_NO_THROW(texsynth::build_exemplar_index(s.view(), p));
    p.patch_size = 44;
    expect_refused(s.view(), p, "too small");
  }
  for (float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(), -2e9f}) {
    Pixels b = s;
    b.at(7, 9)[1] = bad;
    expect_refused(b.view(), ok, "(7, 9)");
  }
  auto with = [&](auto change) {
    ExemplarParams p = ok;
    change(p);
    return p;
  };
  expect_refused(s.view(), with([](ExemplarParams& p) { p.appearance_dims = 0; }), "appearance dims");
  expect_refused(s.view(), with([](ExemplarParams& p) { p.appearance_dims = 76; }), "appearance dims");
  expect_refused(s.view(), with([](ExemplarParams& p) { p.patch_dims = 0; }), "patch dims");
  expect_refused(s.view(), with([](ExemplarParams& p) { p.patch_dims = 257; }), "patch dims");
  expect_refused(s.view(), with([](ExemplarParams& p) { p.band_index = true, p.band_width = 0; }), "band width");
  expect_refused(s.view(), with([](ExemplarParams& p) { p.band_index = true, p.band_width = 9; }), "band width");
  expect_refused(s.view(), with([](ExemplarParams& p) { p.hnsw.M = 1; }), "HNSW M");
  expect_refused(s.view(), with([](ExemplarParams& p) { p.hnsw.ef_search = 0; }), "ef_search");
  expect_refused(s.view(), with([](ExemplarParams& p) { p.full_index = false; }), "neither");
  expect_refused(s.view(), with([](ExemplarParams& p) { p.max_megabytes = 0.01; }), "MB (limit 0.01 MB)");
  // 4 channels (alpha) are accepted, and their appearance window has 100 raw dims.
  const Pixels rgba = noise_sample(40, 40, 4);
  const ExemplarIndex e = texsynth::build_exemplar_index(rgba.view(), ok);
  EXPECT_EQ(e.appearance.space.raw_dims(), 100);
  // Queries with k < 1 are refused; k above the origin count is capped.
  std::vector<float> q(30, 0.f);
  EXPECT_THROW(e.full->search(q.data(), 0), std::invalid_argument);
  EXPECT_EQ(e.full->search_exact(q.data(), 100000).size(), size_t(e.full->count()));
}

TEST(PatchesExemplar, MemoryEstimateRefusesLargeSamples) {
  ExemplarParams p;
  p.band_index = true;
  const int64_t big = texsynth::estimate_exemplar_bytes(4096, 4096, 3, p);
  EXPECT_GT(double(big), 1500e6);
  const int64_t small = texsynth::estimate_exemplar_bytes(256, 256, 3, p);
  EXPECT_LT(double(small), 200e6);
  // The estimate covers what the result holds.
  const Pixels s = noise_sample(48, 44);
  const ExemplarIndex e = texsynth::build_exemplar_index(s.view(), small_params());
  EXPECT_GE(e.stats.estimated_bytes, e.stats.index_bytes);
}

TEST(PatchesExemplar, SerializationRoundTripAndCorruptBuffers) {
  const Pixels s = noise_sample(44, 40);
  ExemplarParams p = small_params();
  p.band_index = true;
  const ExemplarIndex e = texsynth::build_exemplar_index(s.view(), p);
  EXPECT_EQ(e.key, texsynth::exemplar_key(s.view(), p));
  const std::vector<uint8_t> bytes = texsynth::serialize_exemplar_index(e);
  const ExemplarIndex back = texsynth::deserialize_exemplar_index(bytes.data(), bytes.size(), e.key);
  EXPECT_TRUE(texsynth::serialize_exemplar_index(back) == bytes);
  EXPECT_EQ(back.appearance.values, e.appearance.values);
  EXPECT_EQ(back.band->reduced, e.band->reduced);
  EXPECT_EQ(back.band->cells, e.band->cells);
  texsynth::Rng rng(2);
  std::vector<float> q(30);
  for (int i = 0; i < 30; ++i) {  // the rebuilt graph answers as the original
    for (auto& v : q) v = float(rng.uniform() * 2 - 1);
    for (int r = 0; r < 2; ++r) {
      const PatchIndex& a = r ? *e.band : *e.full;
      const PatchIndex& b = r ? *back.band : *back.full;
      const auto ma = a.search(q.data(), 5), mb = b.search(q.data(), 5);
      for (size_t k = 0; k < 5; ++k) {
        EXPECT_EQ(ma[k].x, mb[k].x);
        EXPECT_EQ(ma[k].y, mb[k].y);
      }
    }
  }
  // Another key, another parameter set.
  ExemplarParams other = p;
  other.seed = 4;
  EXPECT_NE(texsynth::exemplar_key(s.view(), other), e.key);
  EXPECT_THROW(texsynth::deserialize_exemplar_index(bytes.data(), bytes.size(), e.key + 1), texsynth::CacheError);
  // Truncated anywhere, bytes flipped anywhere.
  for (size_t n = 0; n < bytes.size(); n += std::max<size_t>(1, bytes.size() / 97))
    EXPECT_THROW(texsynth::deserialize_exemplar_index(bytes.data(), n), texsynth::CacheError) << n;
  EXPECT_THROW(texsynth::deserialize_exemplar_index(nullptr, 0), texsynth::CacheError);
  for (size_t at = 0; at < bytes.size(); at += bytes.size() / 61) {
    std::vector<uint8_t> bad = bytes;
    bad[at] ^= 0x5a;
    EXPECT_THROW(texsynth::deserialize_exemplar_index(bad.data(), bad.size()), texsynth::CacheError) << at;
  }
  // Fields that pass the checksum are still validated (a buffer written by a buggy writer).
  auto resealed = [&](size_t at, const void* value, size_t size) {
    std::vector<uint8_t> bad = bytes;
    std::memcpy(bad.data() + at, value, size);
    const uint64_t sum = texsynth::exemplar_checksum(bad.data(), bad.size() - 8);
    std::memcpy(bad.data() + bad.size() - 8, &sum, 8);
    return bad;
  };
  const int32_t huge = 1 << 30, five = 5;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const uint32_t version = 99;
  for (const auto& bad : {resealed(8, &version, 4), resealed(20, &huge, 4), resealed(24, &huge, 4),
                          resealed(28, &five, 4), resealed(32, &huge, 4), resealed(48, &huge, 4),
                          resealed(bytes.size() - 12, &nan, 4), resealed(60, &nan, 4)}) {
    if (bad == bytes) continue;
    EXPECT_THROW(texsynth::deserialize_exemplar_index(bad.data(), bad.size()), texsynth::CacheError);
  }
  // The tail (reduced vectors and the HNSW link lists): all-ones in any 4-byte field is invalid
  // (NaN, a label, level, count or link out of range), checksum or not.
  const uint32_t ones = 0xffffffffu;
  int tried = 0;
  for (size_t at = (bytes.size() * 6 / 10) & ~size_t(3); at + 8 < bytes.size(); at += 4 * 37, ++tried) {
    const auto bad = resealed(at, &ones, 4);
    if (bad == bytes) continue;
    EXPECT_THROW(texsynth::deserialize_exemplar_index(bad.data(), bad.size()), texsynth::CacheError) << at;
  }
  EXPECT_GT(tried, 100);
  // Files: round trip, missing file.
  texsynth_test::TempDir dir;
  texsynth::save_exemplar_index(e, dir.file("x.tsexemplar"));
  EXPECT_EQ(dir.entry_count(), 1u);  // no temporary left behind
  const ExemplarIndex from_file = texsynth::load_exemplar_index(dir.file("x.tsexemplar"), e.key);
  EXPECT_EQ(from_file.full->reduced, e.full->reduced);
  EXPECT_THROW(texsynth::load_exemplar_index(dir.file("missing")), texsynth::CacheError);
}

// A cache file cut short (a full disk, a killed write) is a CacheError, as with the other caches,
// so callers rebuild it instead of reporting bad input.
TEST(PatchesExemplar, TruncatedCacheFileIsACacheError) {
  const Pixels s = noise_sample(40, 40);
  const ExemplarIndex e = texsynth::build_exemplar_index(s.view(), small_params());
  texsynth_test::TempDir dir;
  const std::string path = dir.file("cut.tsexemplar");
  texsynth::save_exemplar_index(e, path);
  const uintmax_t full = std::filesystem::file_size(path);
  for (const uintmax_t keep : {full - 1, full / 2, uintmax_t(7)}) {
    std::filesystem::resize_file(path, keep);
    try {
      texsynth::load_exemplar_index(path, e.key);
      ADD_FAILURE() << "a " << keep << "-byte file loaded";
    } catch (const texsynth::CacheError& error) {
      EXPECT_NE(std::string(error.what()).find("cut.tsexemplar"), std::string::npos) << error.what();
    } catch (const std::exception& error) {
      ADD_FAILURE() << keep << " bytes: not a CacheError: " << error.what();
    }
  }
}

TEST(PatchesExemplar, CancelAndProgress) {
  const Pixels s = noise_sample(64, 64);
  ExemplarParams p = small_params();
  std::atomic<bool> cancel{true};
  p.cancel = &cancel;
  EXPECT_THROW(texsynth::build_exemplar_index(s.view(), p), texsynth::Cancelled);
  // Raised while the graph is being built (progress past the appearance stage).
  std::atomic<float> progress{0.f};
  cancel = false;
  p.progress = &progress;
  p.tileable = true;
  std::thread raiser([&] {
    while (progress.load() < 0.3f) std::this_thread::yield();
    cancel = true;
  });
  EXPECT_THROW(texsynth::build_exemplar_index(s.view(), p), texsynth::Cancelled);
  raiser.join();
  cancel = false;
  const ExemplarIndex e = texsynth::build_exemplar_index(s.view(), p);
  EXPECT_EQ(progress.load(), 1.f);
  const auto bytes = texsynth::serialize_exemplar_index(e);
  cancel = true;
  EXPECT_THROW(texsynth::deserialize_exemplar_index(bytes.data(), bytes.size(), std::nullopt, &cancel),
               texsynth::Cancelled);
}

}  // namespace
