// SPDX-License-Identifier: GPL-3.0-or-later
// Particle analysis, touching elements (issue 30; texture_particles.md, "Touching elements"): the background
// class chosen as the one with the largest connected piece (the gaps' lace), and the foreground split into
// elements by a watershed of its distance to the background, basins merged by persistence.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <utility>
#include <vector>

#include "analysis_internal.hpp"
#include "texsynth/common/errors.hpp"

namespace texsynth {
namespace particle_detail {

namespace {

// The 8 neighbours of pixel (x, y): calls f(j) for each one inside the sample (wrapped when tileable).
template <class F>
inline void for_neighbours(int32_t x, int32_t y, int32_t W, int32_t H, bool tileable, F&& f) {
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      if (dx == 0 && dy == 0) continue;
      int32_t nx = x + dx, ny = y + dy;
      if (tileable) {
        nx = wrap(nx, W), ny = wrap(ny, H);
      } else if (nx < 0 || ny < 0 || nx >= W || ny >= H) {
        continue;
      }
      f(size_t(ny) * size_t(W) + size_t(nx), dx != 0 && dy != 0);
    }
}

int32_t find_root(std::vector<int32_t>& parent, int32_t b) {
  while (parent[size_t(b)] != b) {
    parent[size_t(b)] = parent[size_t(parent[size_t(b)])];
    b = parent[size_t(b)];
  }
  return b;
}

}  // namespace

void darker_into_background(ParticleAnalysis& a, const ParticleSample& sample) {
  const size_t N = size_t(a.width) * size_t(a.height);
  const int32_t C = a.channels, K = a.num_classes;
  std::vector<double> sum(size_t(K), 0.0);
  std::vector<int64_t> count(size_t(K), 0);
  for (size_t i = 0; i < N; ++i) {
    const float* px = sample.pixels + i * size_t(C);
    sum[size_t(a.labels[i])] += (double(px[0]) + px[1] + px[2]) / 3.0;
    count[size_t(a.labels[i])]++;
  }
  auto mean = [&](int32_t k) { return count[size_t(k)] ? sum[size_t(k)] / double(count[size_t(k)]) : 0.0; };
  const double lace = mean(a.background);
  // Only when some class is lighter than the lace: elements lighter than the gaps between them, whose
  // shadows are darker. Dark elements on a lighter ground (pebbles.png) would all go.
  bool lighter = false;
  for (int32_t k = 0; k < K; ++k) lighter = lighter || (count[size_t(k)] > 0 && mean(k) > lace);
  if (!lighter) return;
  std::vector<uint8_t> darker(size_t(K), 0);
  for (int32_t k = 0; k < K; ++k) darker[size_t(k)] = count[size_t(k)] > 0 && mean(k) < lace;
  for (size_t i = 0; i < N; ++i)
    if (darker[size_t(a.labels[i])]) a.labels[i] = a.background;
}

int32_t lace_background(const ParticleAnalysis& a, const std::atomic<bool>* cancel) {
  const int32_t W = a.width, H = a.height;
  const size_t N = size_t(W) * size_t(H);
  std::vector<uint8_t> seen(N, 0);
  std::vector<int64_t> largest(size_t(a.num_classes), 0);
  std::vector<size_t> queue;
  for (size_t start = 0; start < N; ++start) {
    if (seen[start]) continue;
    if ((start & 0xffff) == 0) throw_if_cancelled(cancel);
    const int32_t cls = a.labels[start];
    seen[start] = 1;
    queue.assign(1, start);
    for (size_t h = 0; h < queue.size(); ++h) {
      const int32_t x = int32_t(queue[h] % size_t(W)), y = int32_t(queue[h] / size_t(W));
      for_neighbours(x, y, W, H, a.tileable, [&](size_t j, bool) {
        if (seen[j] || a.labels[j] != cls) return;
        seen[j] = 1;
        queue.push_back(j);
      });
    }
    largest[size_t(cls)] = std::max(largest[size_t(cls)], int64_t(queue.size()));
  }
  // Ties: the class with more pixels (lower number after k-means), i.e. the first maximum.
  return int32_t(std::max_element(largest.begin(), largest.end()) - largest.begin());
}

std::vector<int32_t> split_touching(ParticleAnalysis& a, const ParticleSample& sample, double neck, double depth,
                                   double shading, const std::atomic<bool>* cancel) {
  const int32_t W = a.width, H = a.height;
  const size_t N = size_t(W) * size_t(H);
  std::vector<int32_t> region(N, -1);
  // Chamfer distance (5 along an axis, 7 diagonally; 5 units = 1 px) to the nearest background pixel: the
  // two raster passes (exact for the 3 x 3 chamfer), repeated while a tileable sample's wrapped neighbours still
  // lower a value. The image border is no background; with no background pixel at all every foreground pixel
  // keeps the same far value (one basin per piece). Memory: one int per pixel.
  constexpr int32_t kAxis = 5, kDiagonal = 7;
  std::vector<int32_t> dist(N, kFar);
  for (size_t i = 0; i < N; ++i)
    if (a.labels[i] == a.background) dist[i] = 0;
  auto relax = [&](size_t i, int32_t x, int32_t y, int dx, int dy, int32_t step) {
    int32_t nx = x + dx, ny = y + dy;
    if (a.tileable) {
      nx = wrap(nx, W), ny = wrap(ny, H);
    } else if (nx < 0 || ny < 0 || nx >= W || ny >= H) {
      return false;
    }
    const int32_t d = dist[size_t(ny) * size_t(W) + size_t(nx)];
    if (d < kFar && d + step < dist[i]) {
      dist[i] = d + step;
      return true;
    }
    return false;
  };
  for (bool changed = true; changed;) {
    changed = false;
    for (int32_t y = 0; y < H; ++y) {
      if ((y & 255) == 0) throw_if_cancelled(cancel);
      for (int32_t x = 0; x < W; ++x) {
        const size_t i = size_t(y) * size_t(W) + size_t(x);
        if (dist[i] == 0) continue;
        changed |= relax(i, x, y, -1, 0, kAxis) | relax(i, x, y, -1, -1, kDiagonal) | relax(i, x, y, 0, -1, kAxis) |
                   relax(i, x, y, 1, -1, kDiagonal);
      }
    }
    for (int32_t y = H - 1; y >= 0; --y) {
      if ((y & 255) == 0) throw_if_cancelled(cancel);
      for (int32_t x = W - 1; x >= 0; --x) {
        const size_t i = size_t(y) * size_t(W) + size_t(x);
        if (dist[i] == 0) continue;
        changed |= relax(i, x, y, 1, 0, kAxis) | relax(i, x, y, 1, 1, kDiagonal) | relax(i, x, y, 0, 1, kAxis) |
                   relax(i, x, y, -1, 1, kDiagonal);
      }
    }
    if (!a.tileable) break;  // exact after one pair of passes without wrapping
  }
  // Shading (optional): the relief is the distance x (1 - shading + shading x min(1, brightness / the
  // foreground's mean brightness)), so that a darker seam where two elements meet becomes a saddle.
  if (shading > 0) {
    const int32_t C = a.channels;
    auto brightness = [&](size_t i) {
      const float* px = sample.pixels + i * size_t(C);
      return (double(px[0]) + px[1] + px[2]) / 3.0;
    };
    double sum = 0;
    int64_t count = 0;
    for (size_t i = 0; i < N; ++i)
      if (a.labels[i] != a.background) sum += brightness(i), count++;
    const double mean = count ? sum / double(count) : 0.0;
    if (mean > 0)
      for (size_t i = 0; i < N; ++i)
        if (a.labels[i] != a.background && dist[i] < kFar) {
          const double f = 1.0 - shading + shading * std::clamp(brightness(i) / mean, 0.0, 1.0);
          dist[i] = std::max<int32_t>(1, int32_t(std::lround(double(dist[i]) * f)));
        }
  }
  // Flooding from the top: foreground pixels by decreasing distance (ties by index). A pixel with no flooded
  // neighbour starts a basin (its peak); else it joins the basin of its highest flooded neighbour, and the
  // basins that meet at it merge when the lower one's peak rises little above this saddle: peak - saddle
  // below `depth` px or saddle above neck x peak (a neck at least that wide is one element's waist, not a join).
  std::vector<size_t> order;
  order.reserve(N);
  for (size_t i = 0; i < N; ++i)
    if (a.labels[i] != a.background) order.push_back(i);
  std::sort(order.begin(), order.end(),
            [&](size_t p, size_t q) { return dist[p] != dist[q] ? dist[p] > dist[q] : p < q; });
  std::vector<int32_t> basin(N, -1), parent, peak;
  std::vector<int32_t> roots;
  for (size_t at = 0; at < order.size(); ++at) {
    if ((at & 0xffff) == 0) throw_if_cancelled(cancel);
    const size_t i = order[at];
    const int32_t d = dist[i];
    int32_t best = -1, best_d = -1;
    roots.clear();
    for_neighbours(int32_t(i % size_t(W)), int32_t(i / size_t(W)), W, H, a.tileable, [&](size_t j, bool) {
      if (basin[j] < 0) return;
      const int32_t r = find_root(parent, basin[j]);
      roots.push_back(r);
      if (dist[j] > best_d) best_d = dist[j], best = r;  // neighbours are visited in a fixed order
    });
    if (best < 0) {
      basin[i] = int32_t(parent.size());
      parent.push_back(basin[i]);
      peak.push_back(d);
      continue;
    }
    basin[i] = best;
    std::sort(roots.begin(), roots.end());
    roots.erase(std::unique(roots.begin(), roots.end()), roots.end());
    if (roots.size() < 2) continue;
    // Highest peak first (ties: lower basin number); the others merge into it when they are no element.
    std::sort(roots.begin(), roots.end(), [&](int32_t p, int32_t q) {
      return peak[size_t(p)] != peak[size_t(q)] ? peak[size_t(p)] > peak[size_t(q)] : p < q;
    });
    for (size_t k = 1; k < roots.size(); ++k) {
      const int32_t r = roots[k], lower = peak[size_t(r)];
      const bool shallow = double(lower - d) < depth * kAxis;  // rises less than `depth` px above the saddle
      const bool waist = double(d) > neck * double(lower);
      if (shallow || waist) parent[size_t(r)] = roots[0];
    }
  }
  // Thin regions (a shadow strip, a rim left in the gaps: peak below kParticleTouchingThin x the peak of the
  // region that holds the median foreground pixel, by peak) go to the background.
  std::vector<int64_t> basin_pixels(parent.size(), 0);
  for (size_t i = 0; i < N; ++i)
    if (basin[i] >= 0) basin_pixels[size_t(find_root(parent, basin[i]))]++;
  std::vector<int32_t> by_peak;
  int64_t total = 0;
  for (int32_t b = 0; b < int32_t(parent.size()); ++b)
    if (basin_pixels[size_t(b)] > 0) by_peak.push_back(b), total += basin_pixels[size_t(b)];
  std::sort(by_peak.begin(), by_peak.end(), [&](int32_t p, int32_t q) {
    return peak[size_t(p)] != peak[size_t(q)] ? peak[size_t(p)] < peak[size_t(q)] : p < q;
  });
  int32_t median_peak = 0;
  int64_t seen = 0;
  for (int32_t b : by_peak) {
    seen += basin_pixels[size_t(b)];
    if (2 * seen >= total) {
      median_peak = peak[size_t(b)];
      break;
    }
  }
  // Regions numbered by the first pixel in row-major order.
  std::vector<int32_t> number(parent.size(), -1);
  int32_t regions = 0;
  for (size_t i = 0; i < N; ++i) {
    if (basin[i] < 0) continue;
    const int32_t r = find_root(parent, basin[i]);
    if (double(peak[size_t(r)]) < kParticleTouchingThin * double(median_peak)) {
      a.labels[i] = a.background;
      continue;
    }
    if (number[size_t(r)] < 0) number[size_t(r)] = regions++;
    region[i] = number[size_t(r)];
  }
  // Each region takes its most frequent class (ties: the lower class number) so that it is one particle.
  std::vector<int32_t> counts(size_t(regions) * size_t(a.num_classes), 0);
  for (size_t i = 0; i < N; ++i)
    if (region[i] >= 0) counts[size_t(region[i]) * size_t(a.num_classes) + size_t(a.labels[i])]++;
  std::vector<int32_t> majority(size_t(regions), 0);
  for (int32_t r = 0; r < regions; ++r) {
    const int32_t* c = &counts[size_t(r) * size_t(a.num_classes)];
    majority[size_t(r)] = int32_t(std::max_element(c, c + a.num_classes) - c);
  }
  for (size_t i = 0; i < N; ++i)
    if (region[i] >= 0) a.labels[i] = majority[size_t(region[i])];
  return region;
}

}  // namespace particle_detail
}  // namespace texsynth
