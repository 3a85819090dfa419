// SPDX-License-Identifier: GPL-3.0-or-later
// Particle analysis, background: the blobs' interior cells (density) and the background fill.
#include <algorithm>
#include <atomic>
#include <utility>
#include <vector>

#include "analysis_internal.hpp"
#include "texsynth/common/errors.hpp"
#include "texsynth/common/hash.hpp"

namespace texsynth {
namespace particle_detail {

// The cells of the sample's blobs (conventions, "Density"): blobs = 8-connected groups of particle pixels of
// any class (a pebble k-means cut into a core and a halo ring is one blob); each pixel belongs to the blob
// nearest it (chessboard distance, two raster passes carrying the owner; ties to the first reached); the
// cells that touch the image border are cut by it and left out. Returns {particles in the interior cells,
// their pixels}. Not for tileable samples.
std::pair<int64_t, int64_t> interior_cells(const ParticleAnalysis& a, const std::atomic<bool>* cancel) {
  const int32_t W = a.width, H = a.height;
  const size_t N = size_t(W) * size_t(H);
  std::vector<int32_t> dist(N, kFar), owner(N, -1);
  int32_t blobs = 0;
  std::vector<size_t> queue;
  for (size_t start = 0; start < N; ++start) {
    if (a.components[start] < 0 || owner[start] >= 0) continue;
    if (blobs % 4096 == 0) throw_if_cancelled(cancel);
    owner[start] = blobs, dist[start] = 0;
    queue.assign(1, start);
    for (size_t h = 0; h < queue.size(); ++h) {
      const int32_t x = int32_t(queue[h] % size_t(W)), y = int32_t(queue[h] / size_t(W));
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int32_t nx = x + dx, ny = y + dy;
          if (nx < 0 || ny < 0 || nx >= W || ny >= H) continue;
          const size_t j = size_t(ny) * W + size_t(nx);
          if (a.components[j] < 0 || owner[j] >= 0) continue;
          owner[j] = blobs, dist[j] = 0;
          queue.push_back(j);
        }
    }
    ++blobs;
  }
  auto relax = [&](size_t i, size_t j) {
    if (dist[j] + 1 < dist[i]) dist[i] = dist[j] + 1, owner[i] = owner[j];
  };
  for (int32_t y = 0; y < H; ++y) {
    if (y % 256 == 0) throw_if_cancelled(cancel);
    for (int32_t x = 0; x < W; ++x) {
      const size_t i = size_t(y) * W + x;
      if (x > 0) relax(i, i - 1);
      if (y > 0) {
        relax(i, i - W);
        if (x > 0) relax(i, i - W - 1);
        if (x + 1 < W) relax(i, i - W + 1);
      }
    }
  }
  for (int32_t y = H - 1; y >= 0; --y) {
    if (y % 256 == 0) throw_if_cancelled(cancel);
    for (int32_t x = W - 1; x >= 0; --x) {
      const size_t i = size_t(y) * W + x;
      if (x + 1 < W) relax(i, i + 1);
      if (y + 1 < H) {
        relax(i, i + W);
        if (x + 1 < W) relax(i, i + W + 1);
        if (x > 0) relax(i, i + W - 1);
      }
    }
  }
  std::vector<int64_t> area(size_t(blobs), 0);
  std::vector<uint8_t> cut(size_t(blobs), 0);
  for (int32_t y = 0; y < H; ++y)
    for (int32_t x = 0; x < W; ++x) {
      const int32_t b = owner[size_t(y) * W + x];
      if (b < 0) continue;
      area[size_t(b)]++;
      if (x == 0 || y == 0 || x == W - 1 || y == H - 1) cut[size_t(b)] = 1;
    }
  int64_t particles = 0, pixels = 0;
  for (int32_t b = 0; b < blobs; ++b)
    if (!cut[size_t(b)]) pixels += area[size_t(b)];
  for (const Particle& p : a.particles) {
    const int32_t* xy = a.pixel_xy.data() + 2 * a.pixel_start[size_t(p.id)];
    particles += !cut[size_t(owner[size_t(xy[1]) * W + size_t(xy[0])])];
  }
  return {particles, pixels};
}

std::pair<int64_t, int64_t> eroded_window(const ParticleAnalysis& a) {
  std::vector<int32_t> reach;
  for (const Particle& p : a.particles)
    if (p.complete) reach.push_back((std::max(p.x1 - p.x0, p.y1 - p.y0) + 2) / 2);
  if (reach.empty()) return {0, 0};
  const size_t rank = std::min(reach.size() - 1, size_t(kParticleReachPercentile * double(reach.size())));
  std::nth_element(reach.begin(), reach.begin() + ptrdiff_t(rank), reach.end());
  const int32_t m = reach[rank];
  const int64_t w = int64_t(a.width) - 2 * int64_t(m), h = int64_t(a.height) - 2 * int64_t(m);
  if (w <= 0 || h <= 0) return {0, 0};
  int64_t inside = 0;
  for (const Particle& p : a.particles)
    inside += p.centroid_x >= float(m) && p.centroid_x < float(a.width - m) && p.centroid_y >= float(m) &&
              p.centroid_y < float(a.height - m);
  return {inside, w * h};
}

void fill_background(ParticleAnalysis& a, const ParticleSample& s, uint64_t seed, const std::atomic<bool>* cancel) {
  const int32_t W = a.width, H = a.height, C = a.channels;
  const size_t N = size_t(W) * size_t(H);
  a.background_fill.assign(s.pixels, s.pixels + N * size_t(C));
  // Unknown = particles dilated by kParticleHalo (separable square max).
  std::vector<uint8_t> mask(N), tmp(N);
  for (size_t i = 0; i < N; ++i) mask[i] = a.components[i] >= 0;
  auto at = [&](int32_t v, int32_t n, bool& inside) {
    inside = a.tileable || (v >= 0 && v < n);
    return a.tileable ? wrap(v, n) : v;
  };
  for (int32_t y = 0; y < H; ++y)
    for (int32_t x = 0; x < W; ++x) {
      uint8_t m = 0;
      for (int d = -kParticleHalo; d <= kParticleHalo && !m; ++d) {
        bool in;
        const int32_t nx = at(x + d, W, in);
        m = in && mask[size_t(y) * W + size_t(nx)];
      }
      tmp[size_t(y) * W + x] = m;
    }
  for (int32_t y = 0; y < H; ++y)
    for (int32_t x = 0; x < W; ++x) {
      uint8_t m = 0;
      for (int d = -kParticleHalo; d <= kParticleHalo && !m; ++d) {
        bool in;
        const int32_t ny = at(y + d, H, in);
        m = in && tmp[size_t(ny) * W + x];
      }
      mask[size_t(y) * W + x] = m;  // 1 = unknown
    }
  throw_if_cancelled(cancel);
  size_t known = 0;
  for (size_t i = 0; i < N; ++i) known += !mask[i];
  if (known == 0) {  // nothing to copy from: the background class colour (or the sample mean)
    const ParticleClass& bg = a.classes[size_t(a.background)];
    std::vector<double> mean(size_t(C), 0.0);
    if (bg.pixels > 0) {
      for (int c = 0; c < C; ++c) mean[size_t(c)] = bg.colour[size_t(c)];
    } else {
      for (size_t i = 0; i < N; ++i)
        for (int c = 0; c < C; ++c) mean[size_t(c)] += s.pixels[i * C + c] / double(N);
    }
    for (size_t i = 0; i < N; ++i)
      for (int c = 0; c < C; ++c) a.background_fill[i * C + c] = float(mean[size_t(c)]);
    return;
  }
  const int ddx[8] = {1, 1, 0, -1, -1, -1, 0, 1}, ddy[8] = {0, 1, 1, 1, 0, -1, -1, -1};
  auto neighbour = [&](size_t i, int k, size_t& j) {
    const int32_t x = int32_t(i % size_t(W)), y = int32_t(i / size_t(W));
    bool in_x, in_y;
    const int32_t nx = at(x + ddx[k], W, in_x), ny = at(y + ddy[k], H, in_y);
    if (!in_x || !in_y) return false;
    j = size_t(ny) * W + size_t(nx);
    return true;
  };
  std::vector<uint8_t> queued(N, 0);
  std::vector<size_t> frontier, next;
  for (size_t i = 0; i < N; ++i) {
    if (!mask[i]) continue;
    for (int k = 0; k < 8; ++k) {
      size_t j;
      if (neighbour(i, k, j) && !mask[j]) {
        frontier.push_back(i);
        queued[i] = 1;
        break;
      }
    }
  }
  for (uint64_t layer = 0; !frontier.empty(); ++layer) {
    throw_if_cancelled(cancel);
    for (size_t i : frontier) {
      size_t sources[8];
      int count = 0;
      for (int k = 0; k < 8; ++k) {
        size_t j;
        if (neighbour(i, k, j) && !mask[j]) sources[count++] = j;
      }
      const size_t from = sources[hash_combine(hash_combine(seed, i), layer) % uint64_t(count)];
      std::copy_n(&a.background_fill[from * C], C, &a.background_fill[i * C]);
    }
    for (size_t i : frontier) mask[i] = 0;
    next.clear();
    for (size_t i : frontier)
      for (int k = 0; k < 8; ++k) {
        size_t j;
        if (neighbour(i, k, j) && mask[j] && !queued[j]) {
          queued[j] = 1;
          next.push_back(j);
        }
      }
    std::sort(next.begin(), next.end());
    frontier.swap(next);
  }
}

}  // namespace particle_detail
}  // namespace texsynth
