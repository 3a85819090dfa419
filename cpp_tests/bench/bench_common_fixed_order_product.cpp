// SPDX-License-Identifier: GPL-3.0-or-later
// Cost of the fixed-order products (common/fixed_order_product.hpp) against Eigen's own, in the same
// run, on the shapes preprocessing uses: the PCA covariance (363 x 8192 times its transpose) and the
// projection of one row of 512 windows (16 x 363 times 363 x 512).
#include <benchmark/benchmark.h>

#include <Eigen/Core>

#include "texsynth/common/fixed_order_product.hpp"
#include "texsynth/common/rng.hpp"

namespace {

Eigen::MatrixXf random_matrix(int rows, int cols, uint64_t seed) {
  texsynth::Rng rng(seed);
  Eigen::MatrixXf m(rows, cols);
  for (Eigen::Index i = 0; i < m.size(); ++i) m.data()[i] = float(rng.uniform() * 2 - 1);
  return m;
}

void BM_CovarianceEigen(benchmark::State& state) {
  const Eigen::MatrixXf a = random_matrix(363, 8192, 1);
  Eigen::MatrixXf out;
  for (auto _ : state) {
    out.noalias() = a * a.transpose();
    benchmark::DoNotOptimize(out.data());
  }
}

void BM_CovarianceFixedOrder(benchmark::State& state) {
  const Eigen::MatrixXf a = random_matrix(363, 8192, 1);
  Eigen::MatrixXf out;
  for (auto _ : state) {
    texsynth::product_fixed_order(out, a, a.transpose());
    benchmark::DoNotOptimize(out.data());
  }
}

void BM_ProjectionEigen(benchmark::State& state) {
  const Eigen::MatrixXf p = random_matrix(16, 363, 2), w = random_matrix(363, 512, 3);
  Eigen::MatrixXf out;
  for (auto _ : state) {
    out.noalias() = p * w;
    benchmark::DoNotOptimize(out.data());
  }
}

void BM_ProjectionFixedOrder(benchmark::State& state) {
  const Eigen::MatrixXf p = random_matrix(16, 363, 2), w = random_matrix(363, 512, 3);
  Eigen::MatrixXf out;
  for (auto _ : state) {
    texsynth::product_fixed_order(out, p, w);
    benchmark::DoNotOptimize(out.data());
  }
}

BENCHMARK(BM_CovarianceEigen)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_CovarianceFixedOrder)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ProjectionEigen)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ProjectionFixedOrder)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
