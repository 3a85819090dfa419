// SPDX-License-Identifier: GPL-3.0-or-later
// Particle analysis, segmentation: k-means classes, connected components, particle geometry.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "analysis_internal.hpp"
#include "texsynth/common/errors.hpp"
#include "texsynth/common/rng.hpp"
#include "texsynth/preprocess/kmeans.hpp"

namespace texsynth {
namespace particle_detail {

// Centre updates as the particle classes always had them (sum / count, an empty class keeps its centre).
constexpr MeanRule kClassMeans{false, false};

// k-means++ fitted on a seeded subsample, every pixel then assigned; classes by decreasing pixel count.
// The assignment and the centre update are preprocess/kmeans.cpp's; the seeding is its own (subsample
// drawn with replacement, double distances, Rng streams 1 and 2): it sets the classes, so the cached
// analyses and every output depend on it.
void kmeans_classes(const std::vector<float>& colours, int32_t n, int C, int k, uint64_t seed,
                    const std::atomic<bool>* cancel, std::vector<int32_t>& labels, std::vector<float>& centres) {
  std::vector<float> sub;
  int32_t m = n;
  if (n <= kParticleKMeansSubsample) {
    sub = colours;
  } else {
    m = kParticleKMeansSubsample;
    sub.resize(size_t(m) * C);
    Rng pick(seed, 1);
    for (int32_t i = 0; i < m; ++i) {
      const uint32_t at = pick.below(uint32_t(n));
      std::copy_n(&colours[size_t(at) * C], C, &sub[size_t(i) * C]);
    }
  }
  Rng rng(seed, 2);
  centres.assign(size_t(k) * C, 0.f);
  std::vector<double> d2(size_t(m), std::numeric_limits<double>::infinity());
  int32_t chosen = int32_t(rng.below(uint32_t(m)));
  for (int j = 0; j < k; ++j) {
    std::copy_n(&sub[size_t(chosen) * C], C, &centres[size_t(j) * C]);
    if (j + 1 == k) break;
    double total = 0;
    for (int32_t i = 0; i < m; ++i) {
      double d = 0;
      for (int c = 0; c < C; ++c) {
        const double e = double(sub[size_t(i) * C + c]) - centres[size_t(j) * C + c];
        d += e * e;
      }
      d2[size_t(i)] = std::min(d2[size_t(i)], d);
      total += d2[size_t(i)];
    }
    if (total <= 0) {  // fewer distinct colours than k: duplicate centres end up empty
      chosen = int32_t(rng.below(uint32_t(m)));
      continue;
    }
    double target = rng.uniform() * total;
    chosen = m - 1;
    for (int32_t i = 0; i < m; ++i) {
      target -= d2[size_t(i)];
      if (target < 0 && d2[size_t(i)] > 0) {
        chosen = i;
        break;
      }
    }
  }
  std::vector<int32_t> sub_labels(size_t(m), -1), nearest(static_cast<size_t>(m));
  for (int it = 0; it < kParticleKMeansIterations; ++it) {
    throw_if_cancelled(cancel);
    assign_brute_force(sub.data(), m, C, centres, k, nearest.data(), cancel);
    if (nearest == sub_labels) break;
    sub_labels.swap(nearest);
    update_centres(sub.data(), m, C, sub_labels.data(), k, seed, it, kClassMeans, centres);
  }
  labels.resize(size_t(n));
  assign_brute_force(colours.data(), n, C, centres, k, labels.data(), cancel);
  std::vector<int64_t> counts(size_t(k), 0);
  for (int32_t l : labels) counts[size_t(l)]++;
  std::vector<int32_t> order(static_cast<size_t>(k));
  for (int j = 0; j < k; ++j) order[size_t(j)] = j;
  std::stable_sort(order.begin(), order.end(), [&](int32_t a, int32_t b) { return counts[size_t(a)] > counts[size_t(b)]; });
  std::vector<int32_t> rank(static_cast<size_t>(k));
  std::vector<float> sorted(centres.size());
  for (int j = 0; j < k; ++j) {
    rank[size_t(order[size_t(j)])] = j;
    std::copy_n(&centres[size_t(order[size_t(j)]) * C], C, &sorted[size_t(j) * C]);
  }
  centres.swap(sorted);
  for (int32_t& l : labels) l = rank[size_t(l)];
}

// 8-connected components of the non-background classes (within one region of split_touching when given);
// merges; ids in first-pixel order.
void find_components(ParticleAnalysis& a, int32_t max_components, const std::atomic<bool>* cancel,
                     const std::vector<int32_t>* region) {
  const int32_t W = a.width, H = a.height;
  const size_t N = size_t(W) * size_t(H);
  std::vector<int32_t> comp(N, -1);
  std::vector<int64_t> start{0};
  std::vector<int32_t> xy;  // unwrapped (x, y), grouped by component, BFS order
  for (int32_t y = 0; y < H; ++y) {
    throw_if_cancelled(cancel);
    for (int32_t x = 0; x < W; ++x) {
      const size_t i = size_t(y) * W + x;
      if (a.labels[i] == a.background || comp[i] >= 0) continue;
      const int32_t id = int32_t(start.size()) - 1, cls = a.labels[i];
      comp[i] = id;
      size_t head = xy.size();
      xy.push_back(x), xy.push_back(y);
      for (; head < xy.size(); head += 2) {
        const int32_t ux = xy[head], uy = xy[head + 1];
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const int32_t nx = ux + dx, ny = uy + dy;
            if (!a.tileable && (nx < 0 || ny < 0 || nx >= W || ny >= H)) continue;
            const size_t j = size_t(wrap(ny, H)) * W + size_t(wrap(nx, W));
            if (a.labels[j] != cls || comp[j] >= 0) continue;
            if (region && (*region)[j] != (*region)[i]) continue;  // touching elements split apart
            comp[j] = id;
            xy.push_back(nx), xy.push_back(ny);
          }
      }
      start.push_back(int64_t(xy.size() / 2));
    }
  }
  const int32_t raw = int32_t(start.size()) - 1;
  std::vector<uint8_t> keep(size_t(raw), 1);
  std::vector<int32_t> survivors;
  for (int32_t c = 0; c < raw; ++c) {
    if (start[size_t(c) + 1] - start[size_t(c)] < a.min_area) {
      keep[size_t(c)] = 0;
      a.merged_small++;
    } else {
      survivors.push_back(c);
    }
  }
  if (int32_t(survivors.size()) > max_components) {  // the largest are kept
    std::stable_sort(survivors.begin(), survivors.end(), [&](int32_t p, int32_t q) {
      return start[size_t(p) + 1] - start[size_t(p)] > start[size_t(q) + 1] - start[size_t(q)];
    });
    for (size_t s = size_t(max_components); s < survivors.size(); ++s) keep[size_t(survivors[s])] = 0;
    a.merged_over_cap = int32_t(survivors.size()) - max_components;
  }
  std::vector<int32_t> new_id(size_t(raw), -1);
  a.pixel_start.assign(1, 0);
  a.pixel_xy.clear();
  if (a.tileable) a.unwrapped.assign(2 * N, 0);
  for (int32_t c = 0; c < raw; ++c) {
    const int64_t b = start[size_t(c)], e = start[size_t(c) + 1];
    if (!keep[size_t(c)]) {
      for (int64_t p = b; p < e; ++p) {
        const size_t i = size_t(wrap(xy[2 * p + 1], H)) * W + size_t(wrap(xy[2 * p], W));
        a.labels[i] = a.background;
        comp[i] = -1;
      }
      continue;
    }
    const int32_t id = int32_t(a.particles.size());
    new_id[size_t(c)] = id;
    Particle part;
    part.id = id;
    part.class_id = a.labels[size_t(xy[2 * b + 1]) * W + size_t(xy[2 * b])];
    part.area = int32_t(e - b);
    // Tileable: move the whole component by whole periods so that its centroid lies inside the sample.
    int32_t shift_x = 0, shift_y = 0;
    if (a.tileable) {
      double mx = 0, my = 0;
      for (int64_t p = b; p < e; ++p) mx += xy[2 * p] + 0.5, my += xy[2 * p + 1] + 0.5;
      shift_x = -int32_t(std::floor(mx / double(e - b) / W)) * W;
      shift_y = -int32_t(std::floor(my / double(e - b) / H)) * H;
    }
    for (int64_t p = b; p < e; ++p) {
      const int32_t ux = xy[2 * p] + shift_x, uy = xy[2 * p + 1] + shift_y;
      a.pixel_xy.push_back(ux), a.pixel_xy.push_back(uy);
      if (a.tileable) {
        const size_t i = size_t(wrap(uy, H)) * W + size_t(wrap(ux, W));
        a.unwrapped[2 * i] = ux, a.unwrapped[2 * i + 1] = uy;
      }
    }
    a.pixel_start.push_back(int64_t(a.pixel_xy.size() / 2));
    a.particles.push_back(part);
  }
  a.components.assign(N, -1);
  for (size_t i = 0; i < N; ++i)
    if (comp[i] >= 0) a.components[i] = new_id[size_t(comp[i])];
}

// Of the particles' outline pixel sides (4-neighbours, wrapped when tileable, none across a plain border),
// the share that faces another particle rather than the background; 0 without particles.
double particle_contact_share(const ParticleAnalysis& a) {
  const int32_t W = a.width, H = a.height;
  int64_t contact = 0, ground = 0;
  for (int32_t y = 0; y < H; ++y)
    for (int32_t x = 0; x < W; ++x) {
      const int32_t own = a.components[size_t(y) * W + x];
      if (own < 0) continue;
      const int32_t nx[4] = {x - 1, x + 1, x, x}, ny[4] = {y, y, y - 1, y + 1};
      for (int k = 0; k < 4; ++k) {
        if (!a.tileable && (nx[k] < 0 || ny[k] < 0 || nx[k] >= W || ny[k] >= H)) continue;
        const int32_t other = a.components[size_t(wrap(ny[k], H)) * W + size_t(wrap(nx[k], W))];
        if (other == own) continue;
        (other >= 0 ? contact : ground)++;
      }
    }
  return contact + ground > 0 ? double(contact) / double(contact + ground) : 0.0;
}

// Centroid, bounding box, PCA box and completeness of one particle.
void particle_geometry(const ParticleAnalysis& a, Particle& part) {
  const int32_t W = a.width, H = a.height;
  const int32_t* xy = a.pixel_xy.data() + 2 * a.pixel_start[size_t(part.id)];
  const int64_t n = part.area;
  double mx = 0, my = 0;
  part.x0 = part.y0 = std::numeric_limits<int32_t>::max();
  part.x1 = part.y1 = std::numeric_limits<int32_t>::min();
  for (int64_t p = 0; p < n; ++p) {
    const int32_t x = xy[2 * p], y = xy[2 * p + 1];
    mx += x + 0.5, my += y + 0.5;
    part.x0 = std::min(part.x0, x), part.x1 = std::max(part.x1, x);
    part.y0 = std::min(part.y0, y), part.y1 = std::max(part.y1, y);
  }
  mx /= double(n), my /= double(n);
  part.centroid_x = float(mx), part.centroid_y = float(my);
  double sxx = 0, syy = 0, sxy = 0;
  for (int64_t p = 0; p < n; ++p) {
    const double dx = xy[2 * p] + 0.5 - mx, dy = xy[2 * p + 1] + 0.5 - my;
    sxx += dx * dx, syy += dy * dy, sxy += dx * dy;
  }
  const double half_diff = 0.5 * (sxx - syy), disc = std::sqrt(half_diff * half_diff + sxy * sxy);
  const double l1 = 0.5 * (sxx + syy) + disc, l2 = 0.5 * (sxx + syy) - disc;
  const double angle = (disc > 0 && l1 >= kParticleOrientedRatio * l2) ? 0.5 * std::atan2(2 * sxy, sxx - syy) : 0.0;
  const double c = std::cos(angle), s = std::sin(angle);
  const double foot = 0.5 * (std::abs(c) + std::abs(s));  // half of a pixel square's shadow on either axis
  double u0 = 1e300, u1 = -1e300, v0 = 1e300, v1 = -1e300;
  for (int64_t p = 0; p < n; ++p) {
    const double dx = xy[2 * p] + 0.5 - mx, dy = xy[2 * p + 1] + 0.5 - my;
    const double u = dx * c + dy * s, v = -dx * s + dy * c;
    u0 = std::min(u0, u), u1 = std::max(u1, u), v0 = std::min(v0, v), v1 = std::max(v1, v);
  }
  const double mu = 0.5 * (u0 + u1), mv = 0.5 * (v0 + v1);
  part.box.cx = float(mx + mu * c - mv * s);
  part.box.cy = float(my + mu * s + mv * c);
  part.box.angle = float(angle);
  part.box.half_x = float(0.5 * (u1 - u0) + foot);
  part.box.half_y = float(0.5 * (v1 - v0) + foot);
  int32_t boundary = 0, border = 0;
  for (int64_t p = 0; p < n; ++p) {
    const int32_t x = xy[2 * p], y = xy[2 * p + 1];
    bool on_boundary = false, outside = false;
    for (auto [dx, dy] : {std::pair{1, 0}, std::pair{-1, 0}, std::pair{0, 1}, std::pair{0, -1}}) {
      const int32_t nx = x + dx, ny = y + dy;
      if (!a.tileable && (nx < 0 || ny < 0 || nx >= W || ny >= H)) {
        on_boundary = outside = true;
        continue;
      }
      if (a.components[size_t(wrap(ny, H)) * W + size_t(wrap(nx, W))] != part.id) on_boundary = true;
    }
    boundary += on_boundary;
    border += outside;
  }
  part.boundary_pixels = boundary, part.border_pixels = border;
  part.complete = a.tileable || double(border) <= kParticleIncompleteFraction * double(boundary);
}

}  // namespace particle_detail
}  // namespace texsynth
