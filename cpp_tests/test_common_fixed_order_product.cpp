// SPDX-License-Identifier: GPL-3.0-or-later
// The same bytes on every x86-64 CPU (common/fixed_order_product.hpp). Eigen picks its matrix-product
// blocking from the L1/L2/L3 sizes it reads with cpuid at run time (32 KB L1 on AMD Zen 4, 48 KB on
// Intel Sapphire Rapids), and the blocking decides the order in which long dot products are summed.
// Here the cache sizes Eigen sees are set to those of several CPUs and the outputs compared bit for bit.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <string>
#include <vector>

#include "synthetic_texture.hpp"
#include "texsynth/common/fixed_order_product.hpp"
#include "texsynth/common/rng.hpp"
#include "texsynth/patches/exemplar_cache.hpp"
#include "texsynth/patches/exemplar_index.hpp"
#include "texsynth/preprocess/preprocess.hpp"

namespace {

struct CacheSizes {
  std::ptrdiff_t l1, l2, l3;
};

// L1d / L2 / L3 as cpuid reports them on a few CPUs (and a small L1, as some hypervisors report).
constexpr CacheSizes kCpus[] = {
    {48 << 10, 2 << 20, 105 << 20},  // Intel Sapphire Rapids
    {32 << 10, 1 << 20, 32 << 20},   // AMD Zen 4 (EPYC 9004)
    {32 << 10, 256 << 10, 8 << 20},  // Intel Skylake client
    {16 << 10, 512 << 10, 4 << 20},  // small L1
};

// Sets the cache sizes Eigen uses for its blocking for one scope.
class EigenCacheSizes {
 public:
  explicit EigenCacheSizes(const CacheSizes& c) {
    Eigen::internal::manage_caching_sizes(Eigen::GetAction, &l1_, &l2_, &l3_);
    Eigen::setCpuCacheSizes(c.l1, c.l2, c.l3);
  }
  ~EigenCacheSizes() { Eigen::setCpuCacheSizes(l1_, l2_, l3_); }

 private:
  std::ptrdiff_t l1_ = 0, l2_ = 0, l3_ = 0;
};

std::string name(const CacheSizes& c) { return "L1 " + std::to_string(c.l1 >> 10) + " KB"; }

Eigen::MatrixXf random_matrix(int rows, int cols, uint64_t seed) {
  texsynth::Rng rng(seed);
  Eigen::MatrixXf m(rows, cols);
  for (Eigen::Index i = 0; i < m.size(); ++i) m.data()[i] = float(rng.uniform() * 2 - 1);
  return m;
}

// The cause, shown on the covariance product preprocessing computes (363 = 11²·3 rows, 8192 samples):
// Eigen's own product differs between the CPUs; the fixed-order one does not.
TEST(CommonFixedOrderProduct, EigenDiffersBetweenCpusTheFixedOrderDoesNot) {
  const Eigen::MatrixXf a = random_matrix(363, 8192, 1);
  std::vector<Eigen::MatrixXf> eigen, fixed;
  for (const CacheSizes& cpu : kCpus) {
    EigenCacheSizes scope(cpu);
    eigen.emplace_back(a * a.transpose());
    Eigen::MatrixXf f;
    texsynth::product_fixed_order(f, a, a.transpose());
    fixed.push_back(f);
  }
  EXPECT_NE(eigen[0], eigen[1]) << "Eigen's blocking no longer depends on the L1 size: revisit the helper";
  for (size_t i = 1; i < fixed.size(); ++i) EXPECT_EQ(fixed[i], fixed[0]) << name(kCpus[i]);
  // Same values up to rounding as the plain product.
  EXPECT_LT((fixed[0] - eigen[0]).cwiseAbs().maxCoeff(), 1e-4f * eigen[0].cwiseAbs().maxCoeff());
}

TEST(CommonFixedOrderProduct, MapDestinationAndShortDepth) {
  const Eigen::MatrixXf a = random_matrix(5, 3, 2), b = random_matrix(3, 7, 3);
  std::vector<float> storage(35, 99.0f);
  Eigen::Map<Eigen::MatrixXf> out(storage.data(), 5, 7);
  texsynth::product_fixed_order(out, a, b);
  // Depth under one chunk: exactly Eigen's product (one block, added to zero).
  EXPECT_EQ(Eigen::MatrixXf(out), Eigen::MatrixXf(a * b));
}

TEST(CommonFixedOrderProduct, PreprocessingIsTheSameWhateverTheCacheSizes) {
  const texsynth::Image image = texsynth_test::brick_texture(160, 128, 3);
  texsynth::PreprocessParams params;
  params.seed = 7;
  std::vector<texsynth::Preprocessed> runs;
  for (const CacheSizes& cpu : kCpus) {
    EigenCacheSizes scope(cpu);
    runs.push_back(texsynth::preprocess(image, params));
  }
  for (size_t i = 1; i < runs.size(); ++i) {
    SCOPED_TRACE(name(kCpus[i]));
    EXPECT_EQ(runs[i].textons, runs[0].textons);
    EXPECT_EQ(runs[i].texton_map, runs[0].texton_map);
    EXPECT_EQ(runs[i].jump_map.targets, runs[0].jump_map.targets);
    EXPECT_EQ(runs[i].jump_map.weights, runs[0].jump_map.weights);
  }
}

TEST(CommonFixedOrderProduct, PatchExemplarIsTheSameWhateverTheCacheSizes) {
  const texsynth::Image image = texsynth_test::gravel_texture(96, 80, 9.0f);
  const texsynth::ExemplarSample sample{image.pixels.data(), image.width, image.height, image.channels};
  texsynth::ExemplarParams params;
  params.patch_size = 16;
  params.seed = 3;
  params.band_index = true;
  std::vector<std::vector<uint8_t>> bytes;
  for (const CacheSizes& cpu : kCpus) {
    EigenCacheSizes scope(cpu);
    bytes.push_back(texsynth::serialize_exemplar_index(texsynth::build_exemplar_index(sample, params)));
  }
  for (size_t i = 1; i < bytes.size(); ++i) EXPECT_TRUE(bytes[i] == bytes[0]) << name(kCpus[i]);
}

}  // namespace
