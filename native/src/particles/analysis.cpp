// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/particles/analysis.hpp"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "texsynth/common/errors.hpp"
#include "texsynth/common/hash.hpp"
#include "texsynth/common/rng.hpp"

namespace texsynth {
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

constexpr double kPi = 3.14159265358979323846;
constexpr int32_t kFar = std::numeric_limits<int32_t>::max() / 2;

inline int32_t wrap(int32_t v, int32_t n) {
  v %= n;
  return v < 0 ? v + n : v;
}

inline void report(std::atomic<float>* progress, float value) {
  if (progress) progress->store(value, std::memory_order_relaxed);
}

// Relative box angle folded to (-pi/2, pi/2] (a box is the same turned by pi).
double fold_angle(double a) {
  while (a > kPi / 2) a -= kPi;
  while (a <= -kPi / 2) a += kPi;
  return a;
}

void validate(const ParticleSample& s, const ParticleAnalysisParams& p) {
  if (!s.pixels) throw std::invalid_argument("particle analysis: sample pixels are missing");
  if (s.channels != 3 && s.channels != 4)
    throw std::invalid_argument("particle analysis: sample must have 3 or 4 channels, got " + std::to_string(s.channels));
  if (s.width < kParticleMinSide || s.height < kParticleMinSide)
    throw std::invalid_argument("particle analysis: sample is too small (" + std::to_string(s.width) + " x " +
                                std::to_string(s.height) + "; each side must be >= " + std::to_string(kParticleMinSide) +
                                " px)");
  if (int64_t(s.width) * s.height > kParticleMaxPixels)
    throw std::invalid_argument("particle analysis: sample is too large (more than 2^28 pixels)");
  const size_t count = size_t(s.width) * size_t(s.height) * size_t(s.channels);
  for (size_t i = 0; i < count; ++i)
    if (!std::isfinite(s.pixels[i])) {
      const size_t pixel = i / size_t(s.channels);
      throw std::invalid_argument("particle analysis: sample pixel (" + std::to_string(pixel % size_t(s.width)) + ", " +
                                  std::to_string(pixel / size_t(s.width)) + ") is NaN or infinite");
    }
  if (p.labels.empty() && (p.classes < kParticleMinClasses || p.classes > kParticleMaxClasses))
    throw std::invalid_argument("particle analysis: classes must be in " + std::to_string(kParticleMinClasses) + ".." +
                                std::to_string(kParticleMaxClasses) + ", got " + std::to_string(p.classes));
  if (!std::isfinite(p.blur_sigma) || p.blur_sigma < 0 || p.blur_sigma > 32)
    throw std::invalid_argument("particle analysis: blur sigma must be in 0..32 px, got " + std::to_string(p.blur_sigma));
  if (p.min_area < 0)
    throw std::invalid_argument("particle analysis: min_area must be >= 0 (0 = default), got " + std::to_string(p.min_area));
  if (p.max_components < 1)
    throw std::invalid_argument("particle analysis: max_components must be >= 1, got " + std::to_string(p.max_components));
  if (!p.labels.empty()) {
    const size_t expected = size_t(s.width) * size_t(s.height);
    if (p.labels.size() != expected)
      throw std::invalid_argument("particle analysis: label image has " + std::to_string(p.labels.size()) +
                                  " values, expected width x height = " + std::to_string(expected));
    for (size_t i = 0; i < expected; ++i)
      if (p.labels[i] < 0 || p.labels[i] >= kParticleMaxLabelClasses)
        throw std::invalid_argument("particle analysis: label at pixel (" + std::to_string(i % size_t(s.width)) + ", " +
                                    std::to_string(i / size_t(s.width)) + ") is " + std::to_string(p.labels[i]) +
                                    "; classes must be in 0.." + std::to_string(kParticleMaxLabelClasses - 1));
  }
}

// Separable Gaussian, radius ceil(3 sigma); borders clamp, or wrap when tileable. Per-row passes.
std::vector<float> gaussian_blur(const ParticleSample& s, double sigma, bool tileable, const std::atomic<bool>* cancel) {
  const int32_t W = s.width, H = s.height, C = s.channels;
  std::vector<float> out(s.pixels, s.pixels + size_t(W) * H * C);
  if (sigma <= 0) return out;
  const int r = std::max(1, int(std::ceil(3 * sigma)));
  std::vector<float> kernel(size_t(2 * r + 1));
  double total = 0;
  for (int i = -r; i <= r; ++i) total += kernel[size_t(i + r)] = float(std::exp(-0.5 * i * i / (sigma * sigma)));
  for (float& k : kernel) k = float(k / total);
  auto index = [&](int32_t v, int32_t n) { return tileable ? wrap(v, n) : std::clamp(v, 0, n - 1); };
  // Separable: along x into tmp, then along y into out (same kernel, fixed order: deterministic).
  std::vector<float> tmp(out.size());
  auto pass = [&](const float* src, float* dst, bool along_x) {
    tbb::parallel_for(tbb::blocked_range<int32_t>(0, H, 16), [&](const tbb::blocked_range<int32_t>& rows) {
      throw_if_cancelled(cancel);
      for (int32_t y = rows.begin(); y < rows.end(); ++y)
        for (int32_t x = 0; x < W; ++x)
          for (int32_t c = 0; c < C; ++c) {
            float acc = 0;
            for (int i = -r; i <= r; ++i) {
              const size_t at = along_x ? size_t(y) * W + index(x + i, W) : size_t(index(y + i, H)) * W + x;
              acc += kernel[size_t(i + r)] * src[at * C + c];
            }
            dst[(size_t(y) * W + x) * C + c] = acc;
          }
    });
  };
  pass(s.pixels, tmp.data(), true);
  pass(tmp.data(), out.data(), false);
  return out;
}

inline int32_t nearest_centre(const float* x, const std::vector<float>& centres, int k, int C) {
  int32_t best = 0;
  float best_d = std::numeric_limits<float>::infinity();
  for (int j = 0; j < k; ++j) {
    float d = 0;
    for (int c = 0; c < C; ++c) {
      const float e = x[c] - centres[size_t(j) * C + c];
      d += e * e;
    }
    if (d < best_d) best_d = d, best = j;  // ties: lower index
  }
  return best;
}

// k-means++ fitted on a seeded subsample, every pixel then assigned; classes by decreasing pixel count.
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
  std::vector<int32_t> sub_labels(size_t(m), -1);
  for (int it = 0; it < kParticleKMeansIterations; ++it) {
    throw_if_cancelled(cancel);
    bool changed = false;
    for (int32_t i = 0; i < m; ++i) {
      const int32_t l = nearest_centre(&sub[size_t(i) * C], centres, k, C);
      changed |= l != sub_labels[size_t(i)];
      sub_labels[size_t(i)] = l;
    }
    if (!changed) break;
    std::vector<double> sums(size_t(k) * C, 0.0);
    std::vector<int64_t> counts(size_t(k), 0);
    for (int32_t i = 0; i < m; ++i) {
      counts[size_t(sub_labels[size_t(i)])]++;
      for (int c = 0; c < C; ++c) sums[size_t(sub_labels[size_t(i)]) * C + c] += sub[size_t(i) * C + c];
    }
    for (int j = 0; j < k; ++j)
      if (counts[size_t(j)] > 0)
        for (int c = 0; c < C; ++c) centres[size_t(j) * C + c] = float(sums[size_t(j) * C + c] / double(counts[size_t(j)]));
  }
  labels.resize(size_t(n));
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, n, 16384), [&](const tbb::blocked_range<int32_t>& r) {
    throw_if_cancelled(cancel);
    for (int32_t i = r.begin(); i < r.end(); ++i) labels[size_t(i)] = nearest_centre(&colours[size_t(i) * C], centres, k, C);
  });
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

// 8-connected components of the non-background classes; merges; ids in first-pixel order.
void find_components(ParticleAnalysis& a, int32_t max_components, const std::atomic<bool>* cancel) {
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

// Signed gaps of neighbour box q (moved by shift) in p's frame (conventions, "Co-occurrences").
CoOccurrence measure_entry(const ParticleBox& p, const ParticleBox& q, double shift_x, double shift_y, int32_t neighbour) {
  const double c = std::cos(double(p.angle)), s = std::sin(double(p.angle));
  const double ox = q.cx + shift_x - p.cx, oy = q.cy + shift_y - p.cy;
  const double a = ox * c + oy * s, b = -ox * s + oy * c;
  const double phi = double(q.angle) - double(p.angle);
  const double cp = std::abs(std::cos(phi)), sp = std::abs(std::sin(phi));
  const double eu = q.half_x * cp + q.half_y * sp, ev = q.half_x * sp + q.half_y * cp;
  const bool pos_x = a > -0.5, pos_y = b > -0.5;
  CoOccurrence e;
  e.quadrant = pos_y ? (pos_x ? 0 : 1) : (pos_x ? 3 : 2);
  e.dx = float((pos_x ? a : -a) - eu - p.half_x);
  e.dy = float((pos_y ? b : -b) - ev - p.half_y);
  e.angle = float(fold_angle(phi));
  e.neighbour = neighbour;
  return e;
}

struct Pt {
  double x, y;
};

std::array<Pt, 4> box_corners(const ParticleBox& b, double shift_x, double shift_y) {
  const double c = std::cos(double(b.angle)), s = std::sin(double(b.angle));
  std::array<Pt, 4> out;
  const double su[4] = {-1, 1, 1, -1}, sv[4] = {-1, -1, 1, 1};  // counter-clockwise
  for (int i = 0; i < 4; ++i) {
    const double u = su[i] * b.half_x, v = sv[i] * b.half_y;
    out[size_t(i)] = {b.cx + shift_x + u * c - v * s, b.cy + shift_y + u * s + v * c};
  }
  return out;
}

// Area of the intersection of two boxes: p clipped by q's four edges (Sutherland-Hodgman).
double box_intersection(const ParticleBox& p, const ParticleBox& q, double shift_x, double shift_y) {
  const auto pc = box_corners(p, 0, 0), qc = box_corners(q, shift_x, shift_y);
  std::vector<Pt> poly(pc.begin(), pc.end()), next;
  for (int e = 0; e < 4 && !poly.empty(); ++e) {
    const Pt a = qc[size_t(e)], b = qc[size_t((e + 1) % 4)];
    auto side = [&](const Pt& x) { return (b.x - a.x) * (x.y - a.y) - (b.y - a.y) * (x.x - a.x); };
    next.clear();
    for (size_t i = 0; i < poly.size(); ++i) {
      const Pt& cur = poly[i];
      const Pt& nxt = poly[(i + 1) % poly.size()];
      const double sc = side(cur), sn = side(nxt);
      if (sc >= 0) next.push_back(cur);
      if ((sc >= 0) != (sn >= 0)) {
        const double t = sc / (sc - sn);
        next.push_back({cur.x + t * (nxt.x - cur.x), cur.y + t * (nxt.y - cur.y)});
      }
    }
    poly.swap(next);
  }
  double area = 0;
  for (size_t i = 0; i < poly.size(); ++i) {
    const Pt& u = poly[i];
    const Pt& v = poly[(i + 1) % poly.size()];
    area += u.x * v.y - v.x * u.y;
  }
  return std::abs(0.5 * area);
}

// Per-thread buffers of the neighbour search.
struct SearchScratch {
  std::vector<int32_t> dist, next;
  std::vector<int32_t> slot;  // per particle: index into found, -1
  struct Found {
    int32_t id, step, shift_x, shift_y;
  };
  std::vector<Found> found;  // same class
  std::vector<Found> other;  // other non-background classes (when asked for)
};

// The kept same-class neighbours of particle id; with `cross`, also the nearest particles of every other
// non-background class within the same window (per class: those at its least step, nearest centres first,
// then lower id, at most kParticleMaxPerQuadrant), in class order.
std::vector<NeighbourHit> search_neighbours(const ParticleAnalysis& a, int32_t id, bool literal, SearchScratch& s,
                                           std::vector<NeighbourHit>* cross = nullptr) {
  const Particle& P = a.particles[size_t(id)];
  const int32_t W = a.width, H = a.height;
  const double size = 2.0 * std::max(P.box.half_x, P.box.half_y);
  const int32_t D = std::max(1, int32_t(std::floor(std::min(kParticleDilationFactor * size, std::min(W, H) / 4.0))));
  int32_t wx0 = P.x0 - D, wx1 = P.x1 + D, wy0 = P.y0 - D, wy1 = P.y1 + D;
  if (!a.tileable) wx0 = std::max(wx0, 0), wy0 = std::max(wy0, 0), wx1 = std::min(wx1, W - 1), wy1 = std::min(wy1, H - 1);
  const int32_t ww = wx1 - wx0 + 1, wh = wy1 - wy0 + 1;
  s.dist.assign(size_t(ww) * size_t(wh), kFar);
  const int32_t* xy = a.pixel_xy.data() + 2 * a.pixel_start[size_t(id)];
  for (int32_t p = 0; p < P.area; ++p) s.dist[size_t(xy[2 * p + 1] - wy0) * ww + size_t(xy[2 * p] - wx0)] = 0;
  if (s.slot.size() != a.particles.size()) s.slot.assign(a.particles.size(), -1);
  s.found.clear();
  s.other.clear();
  // Another particle under window cell (x, y) at distance d: keep its least d (first in raster order). The
  // slot indexes `found` for same-class particles, `other` for the rest.
  auto visit = [&](int32_t x, int32_t y, int32_t d) {
    const int32_t gx = x + wx0, gy = y + wy0;
    const size_t i = size_t(wrap(gy, H)) * W + size_t(wrap(gx, W));
    const int32_t q = a.components[i];
    if (q < 0 || q == id) return;
    const bool same = a.particles[size_t(q)].class_id == P.class_id;
    if (!same && !cross) return;
    std::vector<SearchScratch::Found>& list = same ? s.found : s.other;
    int32_t sx = 0, sy = 0;
    if (a.tileable) sx = gx - a.unwrapped[2 * i], sy = gy - a.unwrapped[2 * i + 1];
    int32_t& at = s.slot[size_t(q)];
    if (at < 0) {
      at = int32_t(list.size());
      list.push_back({q, d, sx, sy});
    } else if (d < list[size_t(at)].step) {
      list[size_t(at)] = {q, d, sx, sy};
    }
  };
  auto quadrant_of = [&](const SearchScratch::Found& f) {
    return measure_entry(P.box, a.particles[size_t(f.id)].box, f.shift_x, f.shift_y, f.id).quadrant;
  };
  if (!literal) {
    // Chessboard distance transform: two raster passes with unit weights are exact.
    auto at = [&](int32_t x, int32_t y) -> int32_t& { return s.dist[size_t(y) * ww + size_t(x)]; };
    for (int32_t y = 0; y < wh; ++y)
      for (int32_t x = 0; x < ww; ++x) {
        int32_t d = at(x, y);
        if (x > 0) d = std::min(d, at(x - 1, y) + 1);
        if (y > 0) {
          d = std::min(d, at(x, y - 1) + 1);
          if (x > 0) d = std::min(d, at(x - 1, y - 1) + 1);
          if (x + 1 < ww) d = std::min(d, at(x + 1, y - 1) + 1);
        }
        at(x, y) = d;
      }
    for (int32_t y = wh - 1; y >= 0; --y)
      for (int32_t x = ww - 1; x >= 0; --x) {
        int32_t d = at(x, y);
        if (x + 1 < ww) d = std::min(d, at(x + 1, y) + 1);
        if (y + 1 < wh) {
          d = std::min(d, at(x, y + 1) + 1);
          if (x + 1 < ww) d = std::min(d, at(x + 1, y + 1) + 1);
          if (x > 0) d = std::min(d, at(x - 1, y + 1) + 1);
        }
        at(x, y) = d;
      }
    for (int32_t y = 0; y < wh; ++y)
      for (int32_t x = 0; x < ww; ++x) {
        const int32_t d = at(x, y);
        if (d > 0 && d <= D) visit(x, y, d);
      }
  } else {
    // The paper's procedure: grow the mask one 3x3 ring per step until every quadrant has a hit.
    bool hit[4] = {false, false, false, false};
    for (int32_t step = 1; step <= D && !(hit[0] && hit[1] && hit[2] && hit[3]); ++step) {
      s.next = s.dist;
      for (int32_t y = 0; y < wh; ++y)
        for (int32_t x = 0; x < ww; ++x) {
          if (s.dist[size_t(y) * ww + size_t(x)] != kFar) continue;
          bool touched = false;
          for (int dy = -1; dy <= 1 && !touched; ++dy)
            for (int dx = -1; dx <= 1 && !touched; ++dx) {
              const int32_t nx = x + dx, ny = y + dy;
              touched = nx >= 0 && ny >= 0 && nx < ww && ny < wh && s.dist[size_t(ny) * ww + size_t(nx)] != kFar;
            }
          if (touched) s.next[size_t(y) * ww + size_t(x)] = step;
        }
      s.dist.swap(s.next);
      const size_t before = s.found.size();
      for (int32_t y = 0; y < wh; ++y)
        for (int32_t x = 0; x < ww; ++x)
          if (s.dist[size_t(y) * ww + size_t(x)] == step) visit(x, y, step);
      for (size_t f = before; f < s.found.size(); ++f) hit[quadrant_of(s.found[f])] = true;
    }
  }
  // Per quadrant: the hits at its least step, nearest centres first, then lower id, at most 2.
  struct Ranked {
    int32_t quadrant, step;
    double centre_d2;
    SearchScratch::Found f;
  };
  std::vector<Ranked> ranked;
  int32_t least[4] = {kFar, kFar, kFar, kFar};
  for (const auto& f : s.found) {
    s.slot[size_t(f.id)] = -1;
    const Particle& Q = a.particles[size_t(f.id)];
    const double ox = Q.box.cx + f.shift_x - P.box.cx, oy = Q.box.cy + f.shift_y - P.box.cy;
    const int32_t q = quadrant_of(f);
    ranked.push_back({q, f.step, ox * ox + oy * oy, f});
    least[q] = std::min(least[q], f.step);
  }
  std::sort(ranked.begin(), ranked.end(), [](const Ranked& u, const Ranked& v) {
    if (u.quadrant != v.quadrant) return u.quadrant < v.quadrant;
    if (u.step != v.step) return u.step < v.step;
    if (u.centre_d2 != v.centre_d2) return u.centre_d2 < v.centre_d2;
    return u.f.id < v.f.id;
  });
  std::vector<NeighbourHit> out;
  int kept[4] = {0, 0, 0, 0};
  for (const Ranked& r : ranked) {
    if (r.step != least[r.quadrant] || kept[r.quadrant] >= kParticleMaxPerQuadrant) continue;
    kept[r.quadrant]++;
    out.push_back({r.f.id, r.quadrant, r.step, r.f.shift_x, r.f.shift_y});
  }
  if (cross) {
    // Per other class: the hits at its least step, nearest centres first, then lower id, at most 2.
    struct Other {
      int32_t cls, step;
      double centre_d2;
      SearchScratch::Found f;
    };
    std::vector<Other> others;
    for (const auto& f : s.other) {
      s.slot[size_t(f.id)] = -1;
      const Particle& Q = a.particles[size_t(f.id)];
      const double ox = Q.box.cx + f.shift_x - P.box.cx, oy = Q.box.cy + f.shift_y - P.box.cy;
      others.push_back({Q.class_id, f.step, ox * ox + oy * oy, f});
    }
    std::sort(others.begin(), others.end(), [](const Other& u, const Other& v) {
      if (u.cls != v.cls) return u.cls < v.cls;
      if (u.step != v.step) return u.step < v.step;
      if (u.centre_d2 != v.centre_d2) return u.centre_d2 < v.centre_d2;
      return u.f.id < v.f.id;
    });
    cross->clear();
    for (size_t i = 0, first = 0; i < others.size(); ++i) {
      if (i == 0 || others[i].cls != others[i - 1].cls) first = i;
      if (others[i].step != others[first].step || i - first >= size_t(kParticleMaxPerQuadrant)) continue;
      const Other& o = others[i];
      cross->push_back({o.f.id, quadrant_of(o.f), o.step, o.f.shift_x, o.f.shift_y});
    }
  } else {
    for (const auto& f : s.other) s.slot[size_t(f.id)] = -1;
  }
  return out;
}

double lower_median(std::vector<float> v) {
  std::nth_element(v.begin(), v.begin() + ptrdiff_t((v.size() - 1) / 2), v.end());
  return v[(v.size() - 1) / 2];
}

// Mean nearest-neighbour distance between centres (wrapped when tileable): sweep over x-sorted copies.
double mean_nearest_distance(const std::vector<Pt>& pts, int32_t W, int32_t H, bool tileable) {
  if (pts.size() < 2) return 0;
  struct Item {
    double x, y;
    int32_t index;
    bool original;
  };
  std::vector<Item> items;
  for (int32_t i = 0; i < int32_t(pts.size()); ++i)
    for (int k = tileable ? -1 : 0; k <= (tileable ? 1 : 0); ++k) items.push_back({pts[size_t(i)].x + k * W, pts[size_t(i)].y, i, k == 0});
  std::sort(items.begin(), items.end(), [](const Item& u, const Item& v) { return u.x != v.x ? u.x < v.x : u.index < v.index; });
  double total = 0;
  for (size_t at = 0; at < items.size(); ++at) {
    if (!items[at].original) continue;
    const Item& me = items[at];
    double best = std::numeric_limits<double>::infinity();
    auto consider = [&](const Item& o) {
      if (o.index == me.index) return;
      double dy = std::abs(o.y - me.y);
      if (tileable) dy = std::min(dy, H - dy);
      best = std::min(best, std::hypot(o.x - me.x, dy));
    };
    for (size_t j = at + 1; j < items.size() && items[j].x - me.x < best; ++j) consider(items[j]);
    for (size_t j = at; j-- > 0 && me.x - items[j].x < best;) consider(items[j]);
    total += best;
  }
  return total / double(pts.size());
}

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

}  // namespace

ParticleAnalysis analyse_particles(const ParticleSample& sample, const ParticleAnalysisParams& params) {
  const auto t_start = Clock::now();
  validate(sample, params);
  const std::atomic<bool>* cancel = params.cancel;
  throw_if_cancelled(cancel);
  ParticleAnalysis a;
  a.width = sample.width, a.height = sample.height, a.channels = sample.channels;
  a.tileable = params.tileable;
  const int32_t W = a.width, H = a.height, C = a.channels;
  const size_t N = size_t(W) * size_t(H);
  a.min_area = params.min_area > 0 ? params.min_area
                                   : std::max<int32_t>(16, int32_t(std::ceil(0.0002 * double(W) * double(H))));

  // Segmentation.
  auto t0 = Clock::now();
  if (params.labels.empty()) {
    const std::vector<float> blurred = gaussian_blur(sample, params.blur_sigma, a.tileable, cancel);
    a.stats.seconds_blur = seconds_since(t0);
    report(params.progress, 0.1f);
    t0 = Clock::now();
    a.num_classes = params.classes;
    kmeans_classes(blurred, int32_t(N), C, params.classes, params.seed, cancel, a.labels, a.centres);
    a.stats.seconds_kmeans = seconds_since(t0);
  } else {
    a.labels = params.labels;
    a.num_classes = *std::max_element(a.labels.begin(), a.labels.end()) + 1;
  }
  report(params.progress, 0.3f);
  std::vector<int64_t> class_pixels(size_t(a.num_classes), 0);
  for (int32_t l : a.labels) class_pixels[size_t(l)]++;
  if (params.background >= a.num_classes || params.background < -1)
    throw std::invalid_argument("particle analysis: background class " + std::to_string(params.background) +
                                " is out of range (classes 0.." + std::to_string(a.num_classes - 1) + ", or -1 = automatic)");
  a.background = params.background >= 0
                     ? params.background
                     : int32_t(std::max_element(class_pixels.begin(), class_pixels.end()) - class_pixels.begin());
  throw_if_cancelled(cancel);

  // Components and per-particle geometry.
  t0 = Clock::now();
  find_components(a, params.max_components, cancel);
  a.stats.seconds_components = seconds_since(t0);
  report(params.progress, 0.45f);
  t0 = Clock::now();
  const int32_t n = int32_t(a.particles.size());
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, n, 16), [&](const tbb::blocked_range<int32_t>& r) {
    throw_if_cancelled(cancel);
    for (int32_t i = r.begin(); i < r.end(); ++i) particle_geometry(a, a.particles[size_t(i)]);
  });
  a.stats.seconds_geometry = seconds_since(t0);
  report(params.progress, 0.55f);

  // Classes: pixels, mean colour, particle counts.
  a.classes.assign(size_t(a.num_classes), ParticleClass{});
  {
    std::vector<double> sums(size_t(a.num_classes) * C, 0.0);
    for (size_t i = 0; i < N; ++i) {
      const int32_t l = a.labels[i];
      a.classes[size_t(l)].pixels++;
      for (int c = 0; c < C; ++c) sums[size_t(l) * C + c] += sample.pixels[i * C + c];
    }
    for (int32_t k = 0; k < a.num_classes; ++k) {
      ParticleClass& cls = a.classes[size_t(k)];
      cls.background = k == a.background;
      if (cls.pixels > 0)
        for (int c = 0; c < C; ++c) cls.colour[size_t(c)] = float(sums[size_t(k) * C + c] / double(cls.pixels));
    }
    for (const Particle& p : a.particles) {
      a.classes[size_t(p.class_id)].particles++;
      a.classes[size_t(p.class_id)].complete += p.complete;
    }
  }

  // Co-occurrences: measured entries per complete particle, in parallel (per-particle results only).
  t0 = Clock::now();
  std::vector<std::vector<CoOccurrence>> measured(static_cast<size_t>(n));
  std::vector<std::vector<std::pair<int32_t, double>>> overlaps(static_cast<size_t>(n));  // (neighbour, overlap fraction)
  struct CrossHit {
    int32_t neighbour;
    double overlap, gap;  // overlap fraction (0 when apart), box gap max(dx, dy) in px
  };
  std::vector<std::vector<CrossHit>> cross(static_cast<size_t>(n));
  tbb::enumerable_thread_specific<SearchScratch> scratch;
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, n, 4), [&](const tbb::blocked_range<int32_t>& r) {
    SearchScratch& s = scratch.local();
    std::vector<NeighbourHit> others;
    for (int32_t i = r.begin(); i < r.end(); ++i) {
      throw_if_cancelled(cancel);
      const Particle& P = a.particles[size_t(i)];
      if (!P.complete) continue;
      auto overlap_of = [&](const Particle& Q, const NeighbourHit& h) {
        const double inter = box_intersection(P.box, Q.box, h.shift_x, h.shift_y);
        const double smaller = std::min(4.0 * P.box.half_x * P.box.half_y, 4.0 * Q.box.half_x * Q.box.half_y);
        return inter > 1e-9 && smaller > 0 ? inter / smaller : 0.0;
      };
      for (const NeighbourHit& h : search_neighbours(a, i, false, s, &others)) {
        const Particle& Q = a.particles[size_t(h.neighbour)];
        measured[size_t(i)].push_back(measure_entry(P.box, Q.box, h.shift_x, h.shift_y, h.neighbour));
        const double f = overlap_of(Q, h);
        if (f > 0) overlaps[size_t(i)].push_back({h.neighbour, f});
      }
      for (const NeighbourHit& h : others) {
        const Particle& Q = a.particles[size_t(h.neighbour)];
        const CoOccurrence e = measure_entry(P.box, Q.box, h.shift_x, h.shift_y, h.neighbour);
        cross[size_t(i)].push_back({h.neighbour, overlap_of(Q, h), double(std::max(e.dx, e.dy))});
      }
    }
  });
  report(params.progress, 0.8f);
  // A neighbour cut by the sample border has the box of its visible part: its gap on the quadrant's side
  // holds, its angle does not (a half leaf at 30 deg reads as 0 or 90). Those entries take the class's
  // median angle towards complete neighbours in the same quadrant (0 when there is none).
  {
    std::vector<std::vector<float>> angles(size_t(a.num_classes) * 4);
    for (int32_t i = 0; i < n; ++i)
      for (const CoOccurrence& e : measured[size_t(i)])
        if (a.particles[size_t(e.neighbour)].complete)
          angles[size_t(a.particles[size_t(i)].class_id) * 4 + size_t(e.quadrant)].push_back(e.angle);
    for (int32_t i = 0; i < n; ++i)
      for (CoOccurrence& e : measured[size_t(i)])
        if (!a.particles[size_t(e.neighbour)].complete) {
          auto& v = angles[size_t(a.particles[size_t(i)].class_id) * 4 + size_t(e.quadrant)];
          e.angle = v.empty() ? 0.0f : float(lower_median(v));
        }
  }
  // Scattered classes: when most quadrants of its complete particles find no neighbour within the
  // dilation cap, the few close pairs would set every gap and propagation would pack the class far
  // denser than the sample (measured: berries 9.8x): such a class is placed like a random one.
  std::vector<int64_t> measured_quadrants(size_t(a.num_classes), 0);
  for (int32_t i = 0; i < n; ++i) {
    std::array<bool, 4> seen{};
    for (const CoOccurrence& e : measured[size_t(i)]) seen[size_t(e.quadrant)] = true;
    measured_quadrants[size_t(a.particles[size_t(i)].class_id)] += seen[0] + seen[1] + seen[2] + seen[3];
  }
  // Class-wide medians of the measured entries, per quadrant.
  std::vector<std::array<std::vector<float>, 3>> per_quadrant(size_t(a.num_classes) * 4);
  for (int32_t i = 0; i < n; ++i)
    for (const CoOccurrence& e : measured[size_t(i)]) {
      auto& v = per_quadrant[size_t(a.particles[size_t(i)].class_id) * 4 + size_t(e.quadrant)];
      v[0].push_back(e.dx), v[1].push_back(e.dy), v[2].push_back(e.angle);
    }
  a.cooc_start.assign(1, 0);
  for (int32_t i = 0; i < n; ++i) {
    const Particle& P = a.particles[size_t(i)];
    std::array<std::vector<CoOccurrence>, 4> quad;
    for (const CoOccurrence& e : measured[size_t(i)]) quad[size_t(e.quadrant)].push_back(e);
    if (P.complete) {
      std::array<bool, 4> real{};
      for (int q = 0; q < 4; ++q) real[size_t(q)] = !quad[size_t(q)].empty();
      for (int q = 0; q < 4; ++q) {
        if (real[size_t(q)] || !real[size_t((q + 2) % 4)]) continue;
        for (CoOccurrence e : quad[size_t((q + 2) % 4)]) {
          e.quadrant = q, e.source = EntrySource::kOpposite;
          quad[size_t(q)].push_back(e);
        }
      }
      for (int q = 0; q < 4; ++q) {
        const auto& m = per_quadrant[size_t(P.class_id) * 4 + size_t(q)];
        if (!quad[size_t(q)].empty() || m[0].empty()) continue;
        CoOccurrence e;
        e.quadrant = q, e.dx = float(lower_median(m[0])), e.dy = float(lower_median(m[1])),
        e.angle = float(lower_median(m[2])), e.neighbour = -1, e.source = EntrySource::kClassMedian;
        quad[size_t(q)].push_back(e);
      }
      for (int q = 0; q < 4; ++q) {
        if (!quad[size_t(q)].empty()) continue;
        for (int from : {q ^ 1, 3 - q}) {
          for (CoOccurrence e : quad[size_t(from)]) {
            if (e.source == EntrySource::kAdjacent) continue;  // never a reflection of a reflection
            e.quadrant = q, e.angle = -e.angle, e.source = EntrySource::kAdjacent;
            quad[size_t(q)].push_back(e);
          }
          if (!quad[size_t(q)].empty()) break;
        }
      }
      for (int q = 0; q < 4; ++q) a.cooc.insert(a.cooc.end(), quad[size_t(q)].begin(), quad[size_t(q)].end());
    }
    a.cooc_start.push_back(int32_t(a.cooc.size()));
  }
  // Overlap tolerance: 95th percentile over distinct overlapping pairs.
  {
    std::vector<std::vector<std::pair<std::pair<int32_t, int32_t>, double>>> pairs(static_cast<size_t>(a.num_classes));
    for (int32_t i = 0; i < n; ++i)
      for (auto [j, f] : overlaps[size_t(i)])
        pairs[size_t(a.particles[size_t(i)].class_id)].push_back({{std::min(i, j), std::max(i, j)}, f});
    for (int32_t k = 0; k < a.num_classes; ++k) {
      auto& v = pairs[size_t(k)];
      std::sort(v.begin(), v.end());
      v.erase(std::unique(v.begin(), v.end(), [](const auto& u, const auto& w) { return u.first == w.first; }), v.end());
      double t = 0.1;
      if (!v.empty()) {
        std::vector<double> f;
        for (const auto& e : v) f.push_back(e.second);
        std::sort(f.begin(), f.end());
        const size_t rank = size_t(std::ceil(0.95 * double(f.size()))) - 1;  // nearest rank
        t = f[std::min(rank, f.size() - 1)] + 0.05;
      }
      a.classes[size_t(k)].tolerance = std::min(t, 0.5);
    }
  }
  // Class pairs (conventions, "Class pairs"): the diagonal from the co-occurrences, the rest from the
  // nearest particles of the other class, both directions pooled.
  {
    const size_t K = size_t(a.num_classes);
    a.class_pairs.assign(K * K, ParticleClassPair{});
    std::vector<std::vector<float>> gaps(K * K);
    std::vector<std::vector<std::pair<std::pair<int32_t, int32_t>, double>>> seen(K * K);  // (pair, overlap)
    auto slot = [&](int32_t k, int32_t j) { return size_t(std::min(k, j)) * K + size_t(std::max(k, j)); };
    for (int32_t i = 0; i < n; ++i) {
      const int32_t k = a.particles[size_t(i)].class_id;
      for (const CoOccurrence& e : measured[size_t(i)]) {
        gaps[slot(k, k)].push_back(std::max(e.dx, e.dy));
        seen[slot(k, k)].push_back({{std::min(i, e.neighbour), std::max(i, e.neighbour)}, 0.0});
      }
      for (const CrossHit& h : cross[size_t(i)]) {
        const int32_t j = a.particles[size_t(h.neighbour)].class_id;
        gaps[slot(k, j)].push_back(float(h.gap));
        seen[slot(k, j)].push_back({{std::min(i, h.neighbour), std::max(i, h.neighbour)}, h.overlap});
      }
    }
    for (int32_t k = 0; k < a.num_classes; ++k)
      for (int32_t j = k; j < a.num_classes; ++j) {
        const size_t at = slot(k, j);
        ParticleClassPair pair;
        auto& v = seen[at];
        std::sort(v.begin(), v.end());
        v.erase(std::unique(v.begin(), v.end(), [](const auto& u, const auto& w) { return u.first == w.first; }),
                v.end());
        pair.pairs = int32_t(v.size());
        if (k == j) {
          pair.tolerance = a.classes[size_t(k)].tolerance;
        } else if (!v.empty()) {
          std::vector<double> f;
          for (const auto& e : v) f.push_back(e.second);
          std::sort(f.begin(), f.end());
          const size_t rank = std::min(size_t(std::ceil(0.95 * double(f.size()))) - 1, f.size() - 1);  // nearest rank
          pair.tolerance = std::min(f[rank] + kParticleCrossSlack, kParticleCrossToleranceCap);
        }
        auto& g = gaps[at];
        if (!g.empty()) {
          const size_t rank = std::min(g.size() - 1, size_t(kParticleGapPercentile * double(g.size())));
          std::nth_element(g.begin(), g.begin() + ptrdiff_t(rank), g.end());
          pair.margin = std::max(0.0, 0.5 * double(g[rank]));
        }
        a.class_pairs[size_t(k) * K + size_t(j)] = a.class_pairs[size_t(j) * K + size_t(k)] = pair;
      }
  }
  // Random classes, densities, minimum distances, classes without a complete particle.
  {
    std::vector<std::vector<Pt>> centres(static_cast<size_t>(a.num_classes));
    for (const Particle& p : a.particles) centres[size_t(p.class_id)].push_back({p.box.cx, p.box.cy});
    // Particles per px^2 over all classes, from the interior cells; shared out by the classes' weights (an
    // incomplete particle counts half: the border cuts large particles more often).
    double total = double(a.particles.size()) / (double(W) * double(H));
    if (!a.tileable && int32_t(a.particles.size()) >= kParticleDensityCells) {
      const auto [inside, pixels] = interior_cells(a, cancel);
      if (inside >= kParticleDensityCells && pixels > 0) total = double(inside) / double(pixels);
    }
    std::vector<double> weight(size_t(a.num_classes), 0.0);
    double weights = 0;
    for (const Particle& p : a.particles) {
      const double w = p.complete ? 1.0 : kParticleIncompleteWeight;
      weight[size_t(p.class_id)] += w, weights += w;
    }
    for (int32_t k = 0; k < a.num_classes; ++k) {
      ParticleClass& cls = a.classes[size_t(k)];
      cls.has_complete = cls.complete > 0;
      if (cls.particles > 0 && !cls.has_complete) a.classes_without_complete++;
      cls.random = (cls.particles >= 1 && cls.particles <= 3) ||
                   (cls.complete > 0 &&
                    double(measured_quadrants[size_t(k)]) < kParticleScatteredFraction * 4.0 * double(cls.complete));
      cls.density = weights > 0 ? total * weight[size_t(k)] / weights : 0.0;
      if (cls.particles == 1) cls.min_distance = 0.7 * std::min(W, H);
      else if (cls.particles > 1) cls.min_distance = 0.7 * mean_nearest_distance(centres[size_t(k)], W, H, a.tileable);
    }
  }
  a.stats.seconds_cooccurrence = seconds_since(t0);
  report(params.progress, 0.9f);

  t0 = Clock::now();
  fill_background(a, sample, params.seed, cancel);
  a.stats.seconds_background = seconds_since(t0);
  a.stats.seconds_total = seconds_since(t_start);
  report(params.progress, 1.f);
  return a;
}

std::vector<NeighbourHit> particle_neighbours(const ParticleAnalysis& analysis, int32_t id, bool literal_dilation) {
  if (id < 0 || id >= int32_t(analysis.particles.size()))
    throw std::invalid_argument("particle neighbours: particle id " + std::to_string(id) + " is out of range (" +
                                std::to_string(analysis.particles.size()) + " particles)");
  SearchScratch s;
  return search_neighbours(analysis, id, literal_dilation, s);
}

ParticleSprite particle_sprite(const ParticleAnalysis& a, const ParticleSample& sample, int32_t id) {
  if (id < 0 || id >= int32_t(a.particles.size()))
    throw std::invalid_argument("particle sprite: particle id " + std::to_string(id) + " is out of range (" +
                                std::to_string(a.particles.size()) + " particles)");
  if (!sample.pixels || sample.width != a.width || sample.height != a.height || sample.channels != a.channels)
    throw std::invalid_argument("particle sprite: the sample must be the analysed one (" + std::to_string(a.width) +
                                " x " + std::to_string(a.height) + " x " + std::to_string(a.channels) + "), got " +
                                std::to_string(sample.width) + " x " + std::to_string(sample.height) + " x " +
                                std::to_string(sample.channels));
  const Particle& P = a.particles[size_t(id)];
  const int32_t pad = kParticleHalo;
  ParticleSprite out;
  out.x0 = P.x0 - pad, out.y0 = P.y0 - pad;
  out.width = P.x1 - P.x0 + 1 + 2 * pad, out.height = P.y1 - P.y0 + 1 + 2 * pad;
  const int32_t sw = out.width, sh = out.height, C = a.channels;
  std::vector<uint8_t> mask(size_t(sw) * size_t(sh), 0);
  const int32_t* xy = a.pixel_xy.data() + 2 * a.pixel_start[size_t(id)];
  for (int32_t p = 0; p < P.area; ++p) mask[size_t(xy[2 * p + 1] - out.y0) * sw + size_t(xy[2 * p] - out.x0)] = 1;
  out.rgba.assign(size_t(sw) * size_t(sh) * 4, 0.f);
  for (int32_t y = 0; y < sh; ++y)
    for (int32_t x = 0; x < sw; ++x) {
      const int32_t gx = x + out.x0, gy = y + out.y0;
      const int32_t sx = a.tileable ? wrap(gx, a.width) : std::clamp(gx, 0, a.width - 1);
      const int32_t sy = a.tileable ? wrap(gy, a.height) : std::clamp(gy, 0, a.height - 1);
      float* dst = &out.rgba[(size_t(y) * sw + x) * 4];
      const float* src = &sample.pixels[(size_t(sy) * a.width + sx) * C];
      dst[0] = src[0], dst[1] = src[1], dst[2] = src[2];
      if (mask[size_t(y) * sw + x]) {
        dst[3] = 1.f;
        continue;
      }
      double d2 = 1e300;
      for (int dy = -pad; dy <= pad; ++dy)
        for (int dx = -pad; dx <= pad; ++dx) {
          const int32_t nx = x + dx, ny = y + dy;
          if (nx >= 0 && ny >= 0 && nx < sw && ny < sh && mask[size_t(ny) * sw + nx]) d2 = std::min(d2, double(dx * dx + dy * dy));
        }
      dst[3] = float(std::max(0.0, 1.0 - std::sqrt(d2) / (pad + 1)));
    }
  return out;
}

}  // namespace texsynth
