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

#include "analysis_internal.hpp"
#include "texsynth/common/errors.hpp"
#include "texsynth/image/blur.hpp"

namespace texsynth {
using namespace particle_detail;

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

inline void report(std::atomic<float>* progress, float value) {
  if (progress) progress->store(value, std::memory_order_relaxed);
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
  if (!(p.touching_neck > 0 && p.touching_neck <= 1))
    throw std::invalid_argument("particle analysis: touching_neck must be in (0, 1], got " + std::to_string(p.touching_neck));
  if (!std::isfinite(p.touching_depth) || p.touching_depth < 0 || p.touching_depth > 1000)
    throw std::invalid_argument("particle analysis: touching_depth must be in 0..1000 px, got " + std::to_string(p.touching_depth));
  if (!(p.touching_shading >= 0 && p.touching_shading <= 1))
    throw std::invalid_argument("particle analysis: touching_shading must be in 0..1, got " + std::to_string(p.touching_shading));
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
    const std::vector<float> blurred = gaussian_blur(sample.pixels, sample.width, sample.height, sample.channels,
                                                     params.blur_sigma, a.tileable && params.wrap_blur, cancel);
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
                     : params.touching
                           ? lace_background(a, cancel)
                           : int32_t(std::max_element(class_pixels.begin(), class_pixels.end()) - class_pixels.begin());
  throw_if_cancelled(cancel);

  // Components and per-particle geometry.
  t0 = Clock::now();
  const bool rims = params.join_rims && params.labels.empty();  // an artist's label image is taken as painted
  auto touching_split = [&](ParticleAnalysis& t) {
    if (params.background < 0 && params.touching_darker) darker_into_background(t, sample);
    const std::vector<int32_t> region = split_touching(t, sample, params.touching_neck, params.touching_depth,
                                                       params.touching_shading, cancel);
    find_components(t, params.max_components, cancel, &region, rims);
    t.touching = true;
  };
  auto geometry = [&](ParticleAnalysis& t) {
    tbb::parallel_for(tbb::blocked_range<int32_t>(0, int32_t(t.particles.size()), 16),
                      [&](const tbb::blocked_range<int32_t>& r) {
                        throw_if_cancelled(cancel);
                        for (int32_t i = r.begin(); i < r.end(); ++i) particle_geometry(t, t.particles[size_t(i)]);
                      });
  };
  // Automatic (conventions, "Touching elements"): the plain components first; the split, from the same k-means
  // labels (copied before find_components merges tiny components into the background), only where one of them
  // spans the sample (a lace or a network of touching elements), kept unless it leaves fewer whole particles.
  const bool automatic = params.touching_auto && !params.touching;
  ParticleAnalysis split;
  if (automatic) {
    split.width = a.width, split.height = a.height, split.channels = a.channels, split.tileable = a.tileable;
    split.num_classes = a.num_classes, split.min_area = a.min_area, split.centres = a.centres, split.labels = a.labels;
  }
  if (params.touching)
    touching_split(a);
  else
    find_components(a, params.max_components, cancel, nullptr, rims);
  int64_t largest = 0;
  for (const Particle& p : a.particles) largest = std::max<int64_t>(largest, p.area);
  const bool spans = double(largest) > kParticleTouchingAutoSpan * double(N);
  // Without a spanning region the split is tried where the particles lie against each other along most of
  // their outlines, and kept only when it makes the sizes more uniform (conventions, "Touching elements"):
  // pieces of one element touch each other and differ in size much more than elements do.
  const bool try_split = automatic && !a.particles.empty() &&
                         (spans || particle_contact_share(a) >= kParticleTouchingAutoContact);
  if (try_split) {
    split.background = params.background >= 0 ? params.background : lace_background(split, cancel);
    touching_split(split);
  }
  a.stats.seconds_components = seconds_since(t0);
  report(params.progress, 0.45f);
  t0 = Clock::now();
  geometry(a);
  if (try_split) {
    geometry(split);
    auto whole_share = [](const ParticleAnalysis& t) {
      int64_t whole = 0;
      for (const Particle& p : t.particles) whole += p.complete;
      return t.particles.empty() ? 0.0 : double(whole) / double(t.particles.size());
    };
    auto log_area_spread = [](const ParticleAnalysis& t) {
      if (t.particles.empty()) return 0.0;
      double sum = 0, sum2 = 0;
      for (const Particle& p : t.particles) {
        const double v = std::log(double(p.area));
        sum += v, sum2 += v * v;
      }
      const double n = double(t.particles.size()), mean = sum / n;
      return std::sqrt(std::max(0.0, sum2 / n - mean * mean));
    };
    const bool fragments =
        !spans && log_area_spread(split) < kParticleTouchingAutoUniform * log_area_spread(a);
    if ((spans || fragments) && !split.particles.empty() && whole_share(split) >= whole_share(a)) {
      split.stats = a.stats;
      a = std::move(split);
      a.touching_fragments = fragments;
    }
  }
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
  const int32_t n = int32_t(a.particles.size());
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
      const auto [in_window, window] = eroded_window(a);
      const double cells = inside >= kParticleDensityCells && pixels > 0 ? double(inside) / double(pixels) : 0.0;
      const double eroded = in_window >= kParticleDensityWindow && window > 0 ? double(in_window) / double(window) : 0.0;
      // Cells are exact for separate elements (an empty margin does not thin them out); touching ones join
      // into blobs that reach the border, and the few small cells left inside overstate the density (the
      // corpus' cobbles 3.6 x, generated packed pebbles 2.6 x): then the eroded window's count holds.
      if (cells > 0 && (eroded == 0 || (cells <= kParticleDensityAgreement * eroded &&
                                        eroded <= kParticleDensityAgreement * cells)))
        total = cells;
      else if (eroded > 0)
        total = eroded;
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
