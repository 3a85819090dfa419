// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <unordered_map>

#include "synthetic_texture.hpp"
#include "temp_dir.hpp"
#include "texsynth/common/errors.hpp"
#include "texsynth/preprocess/cache.hpp"
#include "texsynth/preprocess/preprocess.hpp"

namespace {

std::vector<char> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<char>((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void write_bytes(const std::string& path, const std::vector<char>& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(bytes.data(), std::streamsize(bytes.size()));
}

void expect_same(const texsynth::Preprocessed& a, const texsynth::Preprocessed& b) {
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  EXPECT_EQ(a.sample_width, b.sample_width);
  EXPECT_EQ(a.sample_height, b.sample_height);
  EXPECT_EQ(a.sample_hash, b.sample_hash);
  EXPECT_EQ(texsynth::params_hash(a.params), texsynth::params_hash(b.params));
  EXPECT_EQ(a.num_textons, b.num_textons);
  EXPECT_EQ(a.texton_dims, b.texton_dims);
  EXPECT_EQ(a.texton_map, b.texton_map);
  EXPECT_EQ(a.textons, b.textons);
  EXPECT_EQ(a.texton_distances, b.texton_distances);
  EXPECT_EQ(a.bucket_start, b.bucket_start);
  EXPECT_EQ(a.bucket_pixels, b.bucket_pixels);
  EXPECT_EQ(a.jump_map.k, b.jump_map.k);
  EXPECT_EQ(a.jump_map.targets, b.jump_map.targets);
  EXPECT_EQ(a.jump_map.weights, b.jump_map.weights);
}

class Cache : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    image_ = new texsynth::Image(texsynth_test::brick_texture(40, 30, 8));
    params_ = new texsynth::PreprocessParams();
    params_->seed = 5;
    result_ = new texsynth::Preprocessed(texsynth::preprocess(*image_, *params_));
  }
  static void TearDownTestSuite() {
    delete image_;
    delete params_;
    delete result_;
  }
  void expect_cache_error(const std::vector<char>& bytes, const std::string& fragment = "") {
    write_bytes(dir_.file("bad.tscache"), bytes);
    try {
      texsynth::load_preprocessed(dir_.file("bad.tscache"));
      ADD_FAILURE() << "accepted a bad cache (" << fragment << ")";
    } catch (const texsynth::CacheError& e) {
      if (!fragment.empty()) EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
  }
  std::vector<char> saved() {
    texsynth::save_preprocessed(*result_, dir_.file("good.tscache"));
    return read_bytes(dir_.file("good.tscache"));
  }
  // Rewrites the trailing checksum so only the semantic checks can catch an edit.
  static void fix_checksum(std::vector<char>& bytes) {
    const uint64_t sum = texsynth::cache_checksum(bytes.data(), bytes.size() - 8);
    std::memcpy(bytes.data() + bytes.size() - 8, &sum, 8);
  }
  texsynth_test::TempDir dir_;
  static texsynth::Image* image_;
  static texsynth::PreprocessParams* params_;
  static texsynth::Preprocessed* result_;
};
texsynth::Image* Cache::image_ = nullptr;
texsynth::PreprocessParams* Cache::params_ = nullptr;
texsynth::Preprocessed* Cache::result_ = nullptr;

TEST_F(Cache, RoundTripIsExactAndWithinBudget) {
  const auto bytes = saved();
  const auto loaded = texsynth::load_preprocessed(dir_.file("good.tscache"), result_->sample_hash);
  expect_same(*result_, loaded);
  EXPECT_TRUE(loaded.cache_hit);
  EXPECT_LE(double(bytes.size()), 32.0 * result_->pixel_count() + 4.0 * result_->textons.size() + 200);
  EXPECT_EQ(dir_.entry_count(), 1u) << "temporary file left behind";
}

TEST_F(Cache, EveryFlippedByteIsRejected) {
  const auto good = saved();
  // Header, payload and checksum: every byte position in the first 200, then a stride over the rest.
  for (size_t at = 0; at < good.size(); at += (at < 200 ? 1 : 61)) {
    auto bad = good;
    bad[at] = char(bad[at] ^ 0x10);
    expect_cache_error(bad);
  }
  auto bad = good;
  bad.back() = char(bad.back() ^ 1);
  expect_cache_error(bad, "checksum");
}

TEST_F(Cache, TruncatedOrExtendedFilesAreRejected) {
  const auto good = saved();
  for (size_t size : {size_t(0), size_t(5), size_t(40), size_t(90), good.size() / 2, good.size() - 1})
    expect_cache_error(std::vector<char>(good.begin(), good.begin() + std::ptrdiff_t(size)), "truncated");
  auto longer = good;
  longer.push_back(0);
  expect_cache_error(longer, "trailing");
}

TEST_F(Cache, VersionMagicAndHashMismatchesAreRejected) {
  const auto good = saved();
  auto bad = good;
  bad[8] = 1;  // format version 1 (before working_size)
  fix_checksum(bad);
  expect_cache_error(bad, "format version 1");
  bad = good;
  bad[0] = 'X';
  fix_checksum(bad);
  expect_cache_error(bad, "bad magic");
  write_bytes(dir_.file("other.tscache"), good);
  EXPECT_THROW(texsynth::load_preprocessed(dir_.file("other.tscache"), result_->sample_hash + 1), texsynth::CacheError);
  EXPECT_NO_THROW(texsynth::load_preprocessed(dir_.file("other.tscache"), result_->sample_hash));
}

TEST_F(Cache, ValidChecksumDoesNotMakeBadValuesTrusted) {
  const auto good = saved();
  const size_t header = 96;
  const size_t n = size_t(result_->pixel_count());
  auto bad = good;
  const uint16_t label = uint16_t(result_->num_textons);  // one past the last texton
  std::memcpy(bad.data() + header, &label, 2);
  fix_checksum(bad);
  expect_cache_error(bad, "texton label out of range");

  bad = good;
  const int32_t target = int32_t(n);  // one past the last pixel
  const size_t targets_at = header + 2 * n + 4 * result_->textons.size();
  std::memcpy(bad.data() + targets_at, &target, 4);
  fix_checksum(bad);
  expect_cache_error(bad, "jump target out of range");

  bad = good;
  const size_t weights_at = targets_at + 4 * n * result_->jump_map.k;
  const uint16_t full = 65535;
  for (int i = 0; i < 2; ++i) std::memcpy(bad.data() + weights_at + 2 * i, &full, 2);
  fix_checksum(bad);
  expect_cache_error(bad, "sum to more than 1");

  bad = good;
  const int32_t huge = 1 << 30;  // width: must not lead to a giant allocation
  std::memcpy(bad.data() + 64, &huge, 4);
  fix_checksum(bad);
  expect_cache_error(bad, "image size");
}

TEST_F(Cache, PreprocessCachedHitsMissesAndRecomputesCorruptFiles) {
  const std::string cache_dir = dir_.file("cache");
  const std::string path = texsynth::cache_file_path(cache_dir, texsynth::image_hash(*image_), *params_);
  EXPECT_EQ(texsynth::cache_state(path, texsynth::image_hash(*image_), *params_), texsynth::CacheState::kMissing);
  const auto first = texsynth::preprocess_cached(*image_, *params_, cache_dir);
  EXPECT_FALSE(first.cache_hit);
  EXPECT_EQ(first.cache_status, "miss");
  expect_same(first, *result_);
  EXPECT_EQ(texsynth::cache_state(path, texsynth::image_hash(*image_), *params_), texsynth::CacheState::kFresh);

  const auto second = texsynth::preprocess_cached(*image_, *params_, cache_dir);
  EXPECT_TRUE(second.cache_hit);
  EXPECT_EQ(second.cache_status, "hit");
  expect_same(second, *result_);

  auto bytes = read_bytes(path);
  bytes[bytes.size() / 2] ^= 0x40;
  write_bytes(path, bytes);
  EXPECT_EQ(texsynth::cache_state(path, texsynth::image_hash(*image_), *params_), texsynth::CacheState::kStale);
  const auto third = texsynth::preprocess_cached(*image_, *params_, cache_dir);
  EXPECT_FALSE(third.cache_hit);
  EXPECT_EQ(third.cache_status, "recomputed-corrupt");
  expect_same(third, *result_);
  EXPECT_EQ(texsynth::cache_state(path, texsynth::image_hash(*image_), *params_), texsynth::CacheState::kFresh);

  // Other parameters -> another file name.
  texsynth::PreprocessParams other = *params_;
  other.jump_candidates = 3;
  EXPECT_NE(texsynth::cache_file_path(cache_dir, 1, other), texsynth::cache_file_path(cache_dir, 1, *params_));
}

// Two seeds whose params_hash (32 bits, in the file name) collide share a file name: the file's stored
// parameters, not the hash, must decide whether it is used. Found by a birthday search (~80 000 seeds).
TEST_F(Cache, CollidingParamsHashWithOtherStoredParametersIsStale) {
  std::unordered_map<uint32_t, uint64_t> seen;
  texsynth::PreprocessParams a = *params_, b = *params_;
  for (uint64_t seed = 0;; ++seed) {
    ASSERT_LT(seed, uint64_t(1) << 24) << "no params_hash collision found";
    b.seed = seed;
    const auto [it, inserted] = seen.emplace(texsynth::params_hash(b), seed);
    if (!inserted) {
      a.seed = it->second;
      break;
    }
  }
  ASSERT_EQ(texsynth::params_hash(a), texsynth::params_hash(b));
  ASSERT_FALSE(texsynth::same_params(a, b));
  const std::string cache_dir = dir_.file("collide");
  const uint64_t hash = texsynth::image_hash(*image_);
  const std::string path = texsynth::cache_file_path(cache_dir, hash, b);
  ASSERT_EQ(path, texsynth::cache_file_path(cache_dir, hash, a));

  EXPECT_EQ(texsynth::preprocess_cached(*image_, a, cache_dir).cache_status, "miss");
  EXPECT_EQ(texsynth::cache_state(path, hash, a), texsynth::CacheState::kFresh);
  EXPECT_EQ(texsynth::cache_state(path, hash, b), texsynth::CacheState::kStale);
  const auto recomputed = texsynth::preprocess_cached(*image_, b, cache_dir);
  EXPECT_FALSE(recomputed.cache_hit);
  EXPECT_EQ(recomputed.cache_status, "recomputed-corrupt");
  EXPECT_EQ(recomputed.params.seed, b.seed);
  expect_same(recomputed, texsynth::preprocess(*image_, b));
  EXPECT_EQ(texsynth::load_preprocessed(path, hash).params.seed, b.seed);  // written over a's file
  EXPECT_EQ(texsynth::cache_state(path, hash, b), texsynth::CacheState::kFresh);
  EXPECT_EQ(texsynth::cache_state(path, hash, a), texsynth::CacheState::kStale);
}

TEST(CacheNames, FollowTheDocumentedPattern) {
  texsynth::PreprocessParams p;
  const std::string path = texsynth::cache_file_path("/tmp/x", 0xABCDEFull, p);
  char expected[64];
  std::snprintf(expected, sizeof(expected), "/tmp/x/0000000000abcdef-%08x.tscache", texsynth::params_hash(p));
  EXPECT_EQ(path, expected);
  texsynth::PreprocessParams q = p;
  q.seed = 1;
  EXPECT_NE(texsynth::params_hash(p), texsynth::params_hash(q));
  q = p;
  q.tileable = true;
  EXPECT_NE(texsynth::params_hash(p), texsynth::params_hash(q));
  q = p;
  q.working_size = 2048;
  EXPECT_NE(texsynth::params_hash(p), texsynth::params_hash(q));
}

}  // namespace
