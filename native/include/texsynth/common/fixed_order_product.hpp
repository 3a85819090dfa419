// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Dense matrix products whose rounding is the same on every x86-64 CPU.
//
// Eigen's matrix-matrix product cuts the inner (depth) dimension into blocks sized from the L1 cache
// it reads with cpuid at run time, and sums each block separately: the same product rounds
// differently on a CPU with a 32 KB L1 (AMD Zen 4) and one with 48 KB (Intel Sapphire Rapids).
// Here the depth is cut into fixed chunks of kFixedDepthChunk, small enough that Eigen never cuts
// them again (that needs an L1 under 4.3 KB), and the chunk products are added in order.
// docs/dev/determinism.md has the measurement.
#include <Eigen/Core>
#include <algorithm>

namespace texsynth {

constexpr Eigen::Index kFixedDepthChunk = 64;

// dst = lhs * rhs. dst must already have lhs.rows() × rhs.cols() coefficients (a Map or a matrix);
// it must not alias lhs or rhs.
template <class Dst, class Lhs, class Rhs>
void product_fixed_order(Eigen::MatrixBase<Dst>& dst, const Eigen::MatrixBase<Lhs>& lhs,
                         const Eigen::MatrixBase<Rhs>& rhs) {
  const Eigen::Index depth = lhs.cols();
  dst.setZero();
  for (Eigen::Index j = 0; j < depth; j += kFixedDepthChunk) {
    const Eigen::Index n = std::min(kFixedDepthChunk, depth - j);
    dst.noalias() += lhs.middleCols(j, n) * rhs.middleRows(j, n);
  }
}

// Resizes a plain matrix first.
template <class Scalar, int Options, class Lhs, class Rhs>
void product_fixed_order(Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic, Options>& dst,
                         const Eigen::MatrixBase<Lhs>& lhs, const Eigen::MatrixBase<Rhs>& rhs) {
  dst.resize(lhs.rows(), rhs.cols());
  Eigen::MatrixBase<Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic, Options>>& base = dst;
  product_fixed_order(base, lhs, rhs);
}

}  // namespace texsynth
