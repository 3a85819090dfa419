// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/preprocess/features.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numeric>

#include "texsynth/common/errors.hpp"
#include "texsynth/common/fixed_order_product.hpp"
#include "texsynth/common/rng.hpp"
#include "texsynth/image/border.hpp"

namespace texsynth {
namespace {

struct WindowGatherer {
  int width, height, channels, n, radius;
  std::vector<float> colors;
  std::vector<float> weights;  // n*n Gaussian
  std::vector<float> row_weights;  // the same, repeated per channel: n*n*channels
  std::vector<int> xs, ys;

  WindowGatherer(const Image& image, int neighbourhood, bool tileable)
      : width(image.width), height(image.height), channels(feature_channel_count(image)),
        n(neighbourhood), radius(neighbourhood / 2), colors(to_feature_colors(image)) {
    const double sigma = n / 4.0;
    weights.resize(size_t(n) * n);
    for (int dy = 0; dy < n; ++dy)
      for (int dx = 0; dx < n; ++dx) {
        const double ry = dy - radius, rx = dx - radius;
        weights[size_t(dy) * n + dx] = float(std::exp(-(rx * rx + ry * ry) / (2 * sigma * sigma)));
      }
    xs = border_table(width, radius, tileable);
    ys = border_table(height, radius, tileable);
    row_weights.resize(size_t(n) * n * channels);
    for (int dy = 0; dy < n; ++dy)
      for (int dx = 0; dx < n; ++dx)
        for (int c = 0; c < channels; ++c) row_weights[(size_t(dy) * n + dx) * channels + c] = weights[size_t(dy) * n + dx];
  }

  int dims() const { return n * n * channels; }

  void gather(int x, int y, float* out) const {
    if (x >= radius && x + radius < width) {  // no border in x: each window row is contiguous
      const int span = n * channels;
      for (int dy = 0; dy < n; ++dy) {
        const float* src = colors.data() + (size_t(ys[size_t(y + dy)]) * width + size_t(x - radius)) * channels;
        const float* w = row_weights.data() + size_t(dy) * span;
        float* dst = out + size_t(dy) * span;
        for (int i = 0; i < span; ++i) dst[i] = w[i] * src[i];  // the same products as below
      }
      return;
    }
    int o = 0;
    for (int dy = 0; dy < n; ++dy) {
      const float* row = colors.data() + size_t(ys[size_t(y + dy)]) * size_t(width) * size_t(channels);
      for (int dx = 0; dx < n; ++dx) {
        const float w = weights[size_t(dy) * n + dx];
        const float* px = row + size_t(xs[size_t(x + dx)]) * size_t(channels);
        for (int c = 0; c < channels; ++c) out[o++] = w * px[c];
      }
    }
  }
};

}  // namespace

int full_feature_dims(const Image& image, int neighbourhood) {
  return neighbourhood * neighbourhood * feature_channel_count(image);
}

Features compute_features(const Image& image, int neighbourhood, int feature_dims, bool tileable, uint64_t seed,
                          const std::atomic<bool>* cancel) {
  const WindowGatherer gatherer(image, neighbourhood, tileable);
  const int full_dims = gatherer.dims();
  const int64_t count = image.pixel_count();
  const int width = image.width;
  const bool reduce = feature_dims > 0 && feature_dims < full_dims;
  const int out_dims = reduce ? feature_dims : full_dims;

  // Mean and (when reducing) principal axes from a deterministic subsample.
  const int64_t sample_count = std::min<int64_t>(count, 8192);
  std::vector<int64_t> sample(static_cast<size_t>(sample_count));
  {
    Rng rng(seed, 0x7063612Dull);  // "pca-"
    if (sample_count == count) {
      std::iota(sample.begin(), sample.end(), 0);
    } else {
      for (auto& s : sample) s = int64_t(rng.below(uint32_t(count)));
    }
  }
  Eigen::MatrixXf samples(full_dims, sample_count);
  tbb::parallel_for(tbb::blocked_range<int64_t>(0, sample_count, 256), [&](const tbb::blocked_range<int64_t>& r) {
    for (int64_t i = r.begin(); i < r.end(); ++i)
      gatherer.gather(int(sample[size_t(i)] % width), int(sample[size_t(i)] / width), samples.col(i).data());
  });
  Eigen::VectorXd mean = samples.cast<double>().rowwise().mean();
  const Eigen::VectorXf mean_f = mean.cast<float>();

  Eigen::MatrixXf projection;  // out_dims × full_dims
  throw_if_cancelled(cancel);
  if (reduce) {
    samples.colwise() -= mean_f;
    Eigen::MatrixXf cov_f;
    product_fixed_order(cov_f, samples, samples.transpose());
    cov_f /= float(sample_count);
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> solver(cov_f.cast<double>());
    const Eigen::MatrixXd& vectors = solver.eigenvectors();  // ascending eigenvalues
    projection.resize(out_dims, full_dims);
    for (int i = 0; i < out_dims; ++i) {
      Eigen::VectorXd v = vectors.col(full_dims - 1 - i);
      Eigen::Index largest;
      v.cwiseAbs().maxCoeff(&largest);
      if (v[largest] < 0) v = -v;  // fixed sign: results must not depend on the solver's whim
      projection.row(i) = v.cast<float>().transpose();
    }
  }
  samples.resize(0, 0);
  throw_if_cancelled(cancel);

  Features features;
  features.count = int(count);
  features.dims = out_dims;
  features.values.resize(size_t(count) * size_t(out_dims));
  const Eigen::VectorXf projected_mean = reduce ? Eigen::VectorXf(projection * mean_f) : Eigen::VectorXf();
  tbb::parallel_for(tbb::blocked_range<int>(0, image.height, 1), [&](const tbb::blocked_range<int>& rows) {
    Eigen::MatrixXf windows(full_dims, width);
    Eigen::MatrixXf reduced;
    for (int y = rows.begin(); y < rows.end(); ++y) {
      throw_if_cancelled(cancel);
      for (int x = 0; x < width; ++x) gatherer.gather(x, y, windows.col(x).data());
      float* out = features.values.data() + size_t(y) * size_t(width) * size_t(out_dims);
      if (reduce) {
        product_fixed_order(reduced, projection, windows);
        reduced.colwise() -= projected_mean;
        std::copy(reduced.data(), reduced.data() + reduced.size(), out);
      } else {
        windows.colwise() -= mean_f;
        std::copy(windows.data(), windows.data() + windows.size(), out);
      }
    }
  });
  return features;
}

}  // namespace texsynth
