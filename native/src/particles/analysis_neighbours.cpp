// SPDX-License-Identifier: GPL-3.0-or-later
// Particle analysis, neighbours: the same-class (and cross-class) neighbour search and the box
// measures the co-occurrences are made of.
#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "analysis_internal.hpp"

namespace texsynth {
namespace particle_detail {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Relative box angle folded to (-pi/2, pi/2] (a box is the same turned by pi).
double fold_angle(double a) {
  while (a > kPi / 2) a -= kPi;
  while (a <= -kPi / 2) a += kPi;
  return a;
}

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

}  // namespace

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

// The kept same-class neighbours of particle id; with `cross`, also the nearest particles of every other
// non-background class within the same window (per class: those at its least step, nearest centres first,
// then lower id, at most kParticleMaxPerQuadrant), in class order.
std::vector<NeighbourHit> search_neighbours(const ParticleAnalysis& a, int32_t id, bool literal, SearchScratch& s,
                                           std::vector<NeighbourHit>* cross) {
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

}  // namespace particle_detail

std::vector<NeighbourHit> particle_neighbours(const ParticleAnalysis& analysis, int32_t id, bool literal_dilation) {
  if (id < 0 || id >= int32_t(analysis.particles.size()))
    throw std::invalid_argument("particle neighbours: particle id " + std::to_string(id) + " is out of range (" +
                                std::to_string(analysis.particles.size()) + " particles)");
  particle_detail::SearchScratch s;
  return particle_detail::search_neighbours(analysis, id, literal_dilation, s);
}

}  // namespace texsynth
