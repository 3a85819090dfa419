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

namespace {

// Rims join the particle they lie against (conventions, "Rims"): blurring draws a band of in-between colour
// around an element, k-means gives it a class of its own, and it rings the element's core. A component's
// thickness t is the number of 4-neighbour erosions after which at most kParticleRimInterior of its pixels
// remain (a band w px wide: about w / 2). A component with t <= kParticleRimDepth joins the thicker particle
// (by t) that takes the largest share of its outline sides, when that share is >= kParticleRimContact, its
// colour is a mix of that particle's and the ground's, and it hugs that particle (kParticleRimHug).
// Rounds let a rim of a rim follow (its host joins later); a round's decisions use the state before it.
void join_rims(const ParticleAnalysis& a, const std::vector<int32_t>& comp, const std::vector<int64_t>& start,
               const std::vector<int32_t>& xy, const std::vector<int32_t>* region, const std::atomic<bool>* cancel,
               std::vector<int32_t>& host, std::vector<int32_t>& shift) {
  const int32_t W = a.width, H = a.height, raw = int32_t(start.size()) - 1;
  const size_t N = size_t(W) * size_t(H);
  constexpr int kDx[4] = {-1, 1, 0, 0}, kDy[4] = {0, 0, -1, 1};
  auto pixel_at = [W, H](int32_t x, int32_t y) {  // wrapped index; the modulo only off the sample
    return size_t(uint32_t(y) < uint32_t(H) ? y : wrap(y, H)) * size_t(W) + size_t(uint32_t(x) < uint32_t(W) ? x : wrap(x, W));
  };
  constexpr int rim_depth = kParticleRimDepth;
  // Thickness, 1..rim_depth + 1 (the last: thicker than any rim).
  std::vector<int32_t> thickness(static_cast<size_t>(raw), rim_depth + 1);
  {
    std::vector<uint8_t> deep(N, 0), next(N, 0);
    for (size_t i = 0; i < N; ++i) deep[i] = comp[i] >= 0;
    std::vector<int64_t> left(static_cast<size_t>(raw), 0);
    for (int step = 1; step <= rim_depth; ++step) {
      throw_if_cancelled(cancel);
      std::fill(left.begin(), left.end(), 0);
      for (int32_t y = 0; y < H; ++y)
        for (int32_t x = 0; x < W; ++x) {
          const size_t i = size_t(y) * W + x;
          bool inside = deep[i];
          for (int k = 0; k < 4 && inside; ++k) {
            const int32_t nx = x + kDx[k], ny = y + kDy[k];
            if (!a.tileable && (nx < 0 || ny < 0 || nx >= W || ny >= H)) inside = false;
            else {
              const size_t j = pixel_at(nx, ny);
              inside = deep[j] && comp[j] == comp[i];
            }
          }
          next[i] = inside;
          if (inside) left[size_t(comp[i])]++;
        }
      deep.swap(next);
      for (int32_t c = 0; c < raw; ++c)
        if (thickness[size_t(c)] > rim_depth &&
            double(left[size_t(c)]) <= kParticleRimInterior * double(start[size_t(c) + 1] - start[size_t(c)]))
          thickness[size_t(c)] = step;
    }
  }
  std::vector<int32_t> unwrapped;  // per pixel, its unwrapped (x, y) in its own component's frame
  if (a.tileable) {
    unwrapped.assign(2 * N, 0);
    for (size_t p = 0; p < xy.size() / 2; ++p) {
      const size_t i = size_t(wrap(xy[2 * p + 1], H)) * W + size_t(wrap(xy[2 * p], W));
      unwrapped[2 * i] = xy[2 * p], unwrapped[2 * i + 1] = xy[2 * p + 1];
    }
  }
  // Root of c and c's shift into the root's frame (hosts form chains of strictly growing thickness).
  auto root_of = [&](int32_t c, int32_t& sx, int32_t& sy) {
    sx = sy = 0;
    while (host[size_t(c)] != c) sx += shift[2 * size_t(c)], sy += shift[2 * size_t(c) + 1], c = host[size_t(c)];
    return c;
  };
  struct Tally {
    int32_t root;
    int64_t sides;
    int32_t shift_x, shift_y;  // into the root's frame, from the first side met
  };
  std::vector<Tally> tallies;                      // per candidate, reused
  std::vector<std::pair<int32_t, size_t>> beside;  // (tally, c's pixel next to that root), may repeat
  std::vector<size_t> sources;
  // A rim's colour is a mix of its host's and the ground's: its k-means centre lies within kParticleRimColour
  // x |host - ground| of that segment (colour channels only). A red berry against a grey pebble on sand does not.
  const int C = std::min(a.channels, 3);
  auto class_of = [&](int32_t c) { return a.labels[size_t(wrap(xy[2 * start[size_t(c)] + 1], H)) * W + size_t(wrap(xy[2 * start[size_t(c)]], W))]; };
  auto between = [&](int32_t c, int32_t r) {
    if (a.centres.empty()) return false;
    const float* m = &a.centres[size_t(class_of(c)) * size_t(a.channels)];
    const float* h = &a.centres[size_t(class_of(r)) * size_t(a.channels)];
    const float* g = &a.centres[size_t(a.background) * size_t(a.channels)];
    double hg2 = 0, t = 0;
    for (int k = 0; k < C; ++k) hg2 += double(g[k] - h[k]) * (g[k] - h[k]), t += double(m[k] - h[k]) * (g[k] - h[k]);
    t = hg2 > 0 ? std::clamp(t / hg2, 0.0, 1.0) : 0.0;
    double off2 = 0;
    for (int k = 0; k < C; ++k) {
      const double d = m[k] - (h[k] + t * (g[k] - h[k]));
      off2 += d * d;
    }
    return off2 <= kParticleRimColour * kParticleRimColour * hg2;
  };
  std::vector<int32_t> reach(N, -1);  // BFS steps from the host within the candidate, -1 = not reached
  std::vector<size_t> queue;
  // Share of c's pixels within 2 x rim_depth steps (4-neighbour, inside c) of the pixels next to its host.
  auto hugging_share = [&](int32_t c, const std::vector<size_t>& sources) {
    queue.clear();
    for (size_t i : sources)
      if (reach[i] < 0) reach[i] = 0, queue.push_back(i);
    for (size_t head = 0; head < queue.size(); ++head) {
      const size_t i = queue[head];
      if (reach[i] >= 2 * rim_depth) continue;
      const int32_t x = int32_t(i % size_t(W)), y = int32_t(i / size_t(W));
      for (int k = 0; k < 4; ++k) {
        const int32_t nx = x + kDx[k], ny = y + kDy[k];
        if (!a.tileable && (nx < 0 || ny < 0 || nx >= W || ny >= H)) continue;
        const size_t j = pixel_at(nx, ny);
        if (comp[j] != c || reach[j] >= 0) continue;
        reach[j] = reach[i] + 1;
        queue.push_back(j);
      }
    }
    for (size_t i : queue) reach[i] = -1;
    return double(queue.size()) / double(start[size_t(c) + 1] - start[size_t(c)]);
  };
  // Candidates to look at: all in the first round, then those beside a component that has just joined (the
  // only ones whose neighbours' roots changed).
  std::vector<uint8_t> dirty(static_cast<size_t>(raw), 1);
  for (int round = 0; round < kParticleRimRounds; ++round) {
    throw_if_cancelled(cancel);
    std::vector<std::pair<int32_t, Tally>> joins;
    for (int32_t c = 0; c < raw; ++c) {
      if (thickness[size_t(c)] > rim_depth || host[size_t(c)] != c || !dirty[size_t(c)]) continue;
      tallies.clear();
      beside.clear();
      int64_t outline = 0;
      for (int64_t p = start[size_t(c)]; p < start[size_t(c) + 1]; ++p) {
        const int32_t x = xy[2 * p], y = xy[2 * p + 1];
        const size_t i = size_t(wrap(y, H)) * W + size_t(wrap(x, W));
        for (int k = 0; k < 4; ++k) {
          const int32_t nx = x + kDx[k], ny = y + kDy[k];
          if (!a.tileable && (nx < 0 || ny < 0 || nx >= W || ny >= H)) continue;
          const size_t j = pixel_at(nx, ny);
          const int32_t n = comp[j];
          if (n == c) continue;
          outline++;
          if (n < 0 || (region && (*region)[j] != (*region)[i])) continue;
          if (host[size_t(n)] == n && thickness[size_t(n)] <= thickness[size_t(c)]) continue;  // the common case
          int32_t nsx, nsy;
          const int32_t r = root_of(n, nsx, nsy);
          if (r == c || thickness[size_t(r)] <= thickness[size_t(c)]) continue;
          auto t = std::find_if(tallies.begin(), tallies.end(), [&](const Tally& u) { return u.root == r; });
          if (t == tallies.end()) {
            int32_t sx = 0, sy = 0;
            if (a.tileable) {  // put this pixel next to its neighbour in the root's frame
              sx = unwrapped[2 * j] + nsx - kDx[k] - x;
              sy = unwrapped[2 * j + 1] + nsy - kDy[k] - y;
            }
            tallies.push_back({r, 0, sx, sy});
            t = tallies.end() - 1;
          }
          t->sides++;
          beside.push_back({int32_t(t - tallies.begin()), i});
        }
      }
      int32_t best = -1;
      for (int32_t t = 0; t < int32_t(tallies.size()); ++t) {
        const Tally& u = tallies[size_t(t)];
        if (best < 0 || u.sides > tallies[size_t(best)].sides ||
            (u.sides == tallies[size_t(best)].sides && u.root < tallies[size_t(best)].root))
          best = t;
      }
      if (best < 0 || double(tallies[size_t(best)].sides) < kParticleRimContact * double(outline) ||
          !between(c, tallies[size_t(best)].root))
        continue;
      sources.clear();
      for (const auto& [t, i] : beside)
        if (t == best) sources.push_back(i);
      if (hugging_share(c, sources) >= kParticleRimHug) joins.push_back({c, tallies[size_t(best)]});
    }
    if (joins.empty()) break;
    std::fill(dirty.begin(), dirty.end(), 0);
    for (const auto& [c, t] : joins) {
      host[size_t(c)] = t.root;
      shift[2 * size_t(c)] = t.shift_x, shift[2 * size_t(c) + 1] = t.shift_y;
      for (int64_t p = start[size_t(c)]; p < start[size_t(c) + 1]; ++p)
        for (int k = 0; k < 4; ++k) {
          const int32_t nx = xy[2 * p] + kDx[k], ny = xy[2 * p + 1] + kDy[k];
          if (!a.tileable && (nx < 0 || ny < 0 || nx >= W || ny >= H)) continue;
          const int32_t n = comp[pixel_at(nx, ny)];
          if (n >= 0) dirty[size_t(n)] = 1;
        }
    }
  }
  // Flatten: every component names its root and its shift into the root's frame.
  std::vector<int32_t> flat_host(host.size()), flat_shift(shift.size());
  for (int32_t c = 0; c < raw; ++c) {
    int32_t sx, sy;
    flat_host[size_t(c)] = root_of(c, sx, sy);
    flat_shift[2 * size_t(c)] = sx, flat_shift[2 * size_t(c) + 1] = sy;
  }
  host.swap(flat_host);
  shift.swap(flat_shift);
}

}  // namespace

// 8-connected components of the non-background classes (within one region of split_touching when given);
// merges; ids in first-pixel order.
void find_components(ParticleAnalysis& a, int32_t max_components, const std::atomic<bool>* cancel,
                     const std::vector<int32_t>* region, bool merge_rims) {
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
  // Rims (conventions, "Rims"): host[c] is the component a thin rim joins (c itself otherwise), shift[c] the
  // whole periods that put its unwrapped pixels next to its host's.
  std::vector<int32_t> host(static_cast<size_t>(raw));
  for (int32_t c = 0; c < raw; ++c) host[size_t(c)] = c;
  std::vector<int32_t> shift(2 * size_t(raw), 0);
  if (merge_rims) join_rims(a, comp, start, xy, region, cancel, host, shift);
  auto root_of = [&](int32_t c) {
    while (host[size_t(c)] != c) c = host[size_t(c)];
    return c;
  };
  // Members of each root (itself first, then its rims in id order) and the root's area.
  std::vector<int32_t> member_start(static_cast<size_t>(raw) + 1, 0), members(static_cast<size_t>(raw));
  std::vector<int64_t> group_area(static_cast<size_t>(raw), 0);
  for (int32_t c = 0; c < raw; ++c) {
    const int32_t r = root_of(c);
    member_start[size_t(r) + 1]++;
    group_area[size_t(r)] += start[size_t(c) + 1] - start[size_t(c)];
  }
  for (int32_t c = 0; c < raw; ++c) member_start[size_t(c) + 1] += member_start[size_t(c)];
  {
    std::vector<int32_t> fill(member_start.begin(), member_start.end() - 1);
    for (int32_t c = 0; c < raw; ++c) members[size_t(fill[size_t(root_of(c))]++)] = c;
  }
  std::vector<uint8_t> keep(size_t(raw), 0);
  std::vector<int32_t> survivors;
  for (int32_t c = 0; c < raw; ++c) {
    if (host[size_t(c)] != c) continue;
    if (group_area[size_t(c)] < a.min_area) {
      a.merged_small++;
    } else {
      keep[size_t(c)] = 1;
      survivors.push_back(c);
    }
  }
  if (int32_t(survivors.size()) > max_components) {  // the largest are kept
    std::stable_sort(survivors.begin(), survivors.end(), [&](int32_t p, int32_t q) {
      return group_area[size_t(p)] > group_area[size_t(q)];
    });
    for (size_t s = size_t(max_components); s < survivors.size(); ++s) keep[size_t(survivors[s])] = 0;
    a.merged_over_cap = int32_t(survivors.size()) - max_components;
  }
  std::vector<int32_t> new_id(size_t(raw), -1);
  a.pixel_start.assign(1, 0);
  a.pixel_xy.clear();
  if (a.tileable) a.unwrapped.assign(2 * N, 0);
  for (int32_t r = 0; r < raw; ++r) {
    if (host[size_t(r)] != r) continue;
    const int32_t class_id = a.labels[size_t(xy[2 * start[size_t(r)] + 1]) * W + size_t(xy[2 * start[size_t(r)]])];
    if (!keep[size_t(r)]) {
      for (int32_t m = member_start[size_t(r)]; m < member_start[size_t(r) + 1]; ++m)
        for (int64_t p = start[size_t(members[size_t(m)])]; p < start[size_t(members[size_t(m)]) + 1]; ++p) {
          const size_t i = size_t(wrap(xy[2 * p + 1], H)) * W + size_t(wrap(xy[2 * p], W));
          a.labels[i] = a.background;
          comp[i] = -1;
        }
      continue;
    }
    const int32_t id = int32_t(a.particles.size());
    Particle part;
    part.id = id;
    part.class_id = class_id;
    part.area = int32_t(group_area[size_t(r)]);
    // Tileable: move the whole group by whole periods so that its centroid lies inside the sample.
    int32_t shift_x = 0, shift_y = 0;
    if (a.tileable) {
      double mx = 0, my = 0;
      for (int32_t m = member_start[size_t(r)]; m < member_start[size_t(r) + 1]; ++m) {
        const int32_t c = members[size_t(m)];
        for (int64_t p = start[size_t(c)]; p < start[size_t(c) + 1]; ++p)
          mx += xy[2 * p] + shift[2 * size_t(c)] + 0.5, my += xy[2 * p + 1] + shift[2 * size_t(c) + 1] + 0.5;
      }
      shift_x = -int32_t(std::floor(mx / double(part.area) / W)) * W;
      shift_y = -int32_t(std::floor(my / double(part.area) / H)) * H;
    }
    for (int32_t m = member_start[size_t(r)]; m < member_start[size_t(r) + 1]; ++m) {
      const int32_t c = members[size_t(m)];
      new_id[size_t(c)] = id;
      for (int64_t p = start[size_t(c)]; p < start[size_t(c) + 1]; ++p) {
        const int32_t ux = xy[2 * p] + shift[2 * size_t(c)] + shift_x, uy = xy[2 * p + 1] + shift[2 * size_t(c) + 1] + shift_y;
        a.pixel_xy.push_back(ux), a.pixel_xy.push_back(uy);
        const size_t i = size_t(wrap(uy, H)) * W + size_t(wrap(ux, W));
        a.labels[i] = class_id;  // a rim takes its host's class
        if (a.tileable) a.unwrapped[2 * i] = ux, a.unwrapped[2 * i + 1] = uy;
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
