// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/patches/coverage.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>

#include "texsynth/common/errors.hpp"
#include "texsynth/common/hash.hpp"
#include "texsynth/mesh/spatial_cells.hpp"

namespace texsynth {
namespace {

constexpr double kCellSlack = 0.01;      // s, t tolerance at cell edges
constexpr double kMaxPlaneDistance = 0.5;  // in local steps
constexpr double kMinNormalDot = 0.5;
constexpr int kMaxWalk = 12;
constexpr double kCandidateCell = 0.5;  // candidate cell / smallest centre spacing

void validate(const PatchField& field, const PatchSamples& s) {
  if (s.count < 0) throw std::invalid_argument("patch samples: negative count");
  if (s.count > 0 && (!s.positions || !s.triangle || !s.barycentric))
    throw std::invalid_argument("patch samples: missing positions, triangles or barycentrics");
  const int32_t nt = int32_t(field.triangles.size() / 3);
  for (int32_t i = 0; i < s.count; ++i) {
    if (s.triangle[i] < 0 || s.triangle[i] >= nt)
      throw std::invalid_argument("patch samples: sample " + std::to_string(i) + " is in triangle " +
                                  std::to_string(s.triangle[i]) + " (mesh has " + std::to_string(nt) + " triangles)");
    for (int k = 0; k < 3; ++k)
      if (!std::isfinite(s.positions[3 * size_t(i) + k]))
        throw std::invalid_argument("patch samples: position of sample " + std::to_string(i) + " is NaN or infinite");
  }
}

double sample_scale(const PatchField& f, const PatchSamples& s, int32_t i) {
  const int32_t* c = &f.triangles[3 * size_t(s.triangle[i])];
  const double b1 = s.barycentric[2 * size_t(i)], b2 = s.barycentric[2 * size_t(i) + 1];
  return (1 - b1 - b2) * f.scale[c[0]] + b1 * f.scale[c[1]] + b2 * f.scale[c[2]];
}

}  // namespace

std::vector<FacePoint> choose_patch_centres(const PatchField& field, const PatchSamples& samples, double spacing,
                                            uint64_t seed, const uint8_t* only, const std::atomic<bool>* cancel) {
  validate(field, samples);
  if (!std::isfinite(spacing) || spacing <= 0) throw std::invalid_argument("patch centres: spacing must be > 0");
  const int32_t n = samples.count;
  std::vector<float> radius(static_cast<size_t>(n));
  double cell = std::numeric_limits<double>::infinity();
  for (int32_t i = 0; i < n; ++i) {
    radius[i] = float(spacing * field.spacing * sample_scale(field, samples, i));
    if (!only || only[i]) cell = std::min(cell, double(radius[i]));
  }
  std::vector<FacePoint> out;
  if (!std::isfinite(cell)) return out;
  // Cells of half the smallest radius: with one candidate per cell of the whole radius, samples of a
  // rejected cell could be up to 2r from every centre, and at 1024² the extra round then needed 1057
  // patches on top of 1734 (README, Vector-field patches).
  cell *= kCandidateCell;
  throw_if_cancelled(cancel);
  // One candidate per occupied cell: the sample with the smallest seeded hash.
  struct Candidate {
    uint64_t key, rank;
    int32_t sample;
  };
  // The smallest rank per cell in one pass over the samples (sorting every sample by cell was 0.1-0.2 s
  // at a million samples).
  std::unordered_map<uint64_t, Candidate> best;
  for (int32_t i = 0; i < n; ++i) {
    if (only && !only[i]) continue;
    int64_t c[3];
    if (!spatial_cell(v3(samples.positions + 3 * size_t(i)), cell, c)) continue;
    const Candidate cand{spatial_cell_key(c[0], c[1], c[2]), hash_combine(seed, uint64_t(i)), i};
    auto [it, inserted] = best.try_emplace(cand.key, cand);
    if (!inserted && (cand.rank < it->second.rank || (cand.rank == it->second.rank && cand.sample < it->second.sample)))
      it->second = cand;
  }
  std::vector<Candidate> picks;
  picks.reserve(best.size());
  for (const auto& entry : best) picks.push_back(entry.second);
  std::sort(picks.begin(), picks.end(), [](const Candidate& a, const Candidate& b) {
    return a.rank != b.rank ? a.rank < b.rank : a.sample < b.sample;
  });
  throw_if_cancelled(cancel);
  // Dart throwing over the candidates in seeded order.
  std::unordered_map<uint64_t, std::vector<int32_t>> accepted;  // cell -> accepted samples
  for (const Candidate& cand : picks) {
    const V3 p = v3(samples.positions + 3 * size_t(cand.sample));
    const double r = radius[cand.sample];
    int64_t c[3] = {0, 0, 0};
    spatial_cell(p, cell, c);  // succeeded when the candidate was made
    const int64_t reach = int64_t(std::ceil(r / cell));
    bool free = true;
    for (int64_t dx = -reach; dx <= reach && free; ++dx)
      for (int64_t dy = -reach; dy <= reach && free; ++dy)
        for (int64_t dz = -reach; dz <= reach && free; ++dz) {
          auto it = accepted.find(spatial_cell_key(c[0] + dx, c[1] + dy, c[2] + dz));
          if (it == accepted.end()) continue;
          for (int32_t q : it->second)
            if (norm(v3(samples.positions + 3 * size_t(q)) - p) < r) {
              free = false;
              break;
            }
        }
    if (!free) continue;
    accepted[spatial_cell_key(c[0], c[1], c[2])].push_back(cand.sample);
    out.push_back({samples.triangle[cand.sample], samples.barycentric[2 * size_t(cand.sample)],
                   samples.barycentric[2 * size_t(cand.sample) + 1]});
  }
  return out;
}

namespace {

// The patch-major side from the sample-major one (samples ascending within each patch).
void fill_patch_side(PatchCoverage& out, int32_t np) {
  const int32_t count = int32_t(out.sample_start.size()) - 1;
  const size_t total = out.sample_patch.size();
  out.patch_start.assign(size_t(np) + 1, 0);
  for (int32_t p : out.sample_patch) out.patch_start[size_t(p) + 1]++;
  for (int32_t p = 0; p < np; ++p) out.patch_start[size_t(p) + 1] += out.patch_start[p];
  out.patch_sample.resize(total);
  out.patch_uv.resize(2 * total);
  std::vector<int64_t> fill(out.patch_start.begin(), out.patch_start.end() - 1);
  for (int32_t s = 0; s < count; ++s)
    for (int64_t e = out.sample_start[s]; e < out.sample_start[size_t(s) + 1]; ++e) {
      const int64_t slot = fill[out.sample_patch[e]]++;
      out.patch_sample[slot] = s;
      out.patch_uv[2 * slot] = out.sample_uv[2 * e], out.patch_uv[2 * slot + 1] = out.sample_uv[2 * e + 1];
    }
}

}  // namespace

PatchCoverage merge_coverage(const PatchCoverage& a, const PatchCoverage& b) {
  if (a.sample_start.size() != b.sample_start.size() || a.sample_start.empty())
    throw std::invalid_argument("merge coverage: different sample counts");
  const int32_t count = int32_t(a.sample_start.size()) - 1;
  const int32_t np = int32_t(std::max(a.patch_start.size(), b.patch_start.size())) - 1;
  PatchCoverage out;
  out.sample_start.assign(size_t(count) + 1, 0);
  for (int32_t s = 0; s < count; ++s)
    out.sample_start[size_t(s) + 1] = out.sample_start[s] + (a.sample_start[size_t(s) + 1] - a.sample_start[s]) +
                                      (b.sample_start[size_t(s) + 1] - b.sample_start[s]);
  out.sample_patch.resize(size_t(out.sample_start[count]));
  out.sample_uv.resize(2 * size_t(out.sample_start[count]));
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, count, 4096), [&](const tbb::blocked_range<int32_t>& r) {
    for (int32_t s = r.begin(); s < r.end(); ++s) {
      int64_t i = a.sample_start[s], j = b.sample_start[s], at = out.sample_start[s];
      const int64_t ie = a.sample_start[size_t(s) + 1], je = b.sample_start[size_t(s) + 1];
      for (; i < ie || j < je; ++at) {  // both ascending by patch: merged ascending
        const bool from_a = j == je || (i < ie && a.sample_patch[i] <= b.sample_patch[j]);
        const PatchCoverage& src = from_a ? a : b;
        const int64_t e = from_a ? i++ : j++;
        out.sample_patch[at] = src.sample_patch[e];
        out.sample_uv[2 * at] = src.sample_uv[2 * e], out.sample_uv[2 * at + 1] = src.sample_uv[2 * e + 1];
      }
    }
  });
  for (int32_t s = 0; s < count; ++s) out.uncovered += out.sample_start[size_t(s) + 1] == out.sample_start[s];
  fill_patch_side(out, np);
  return out;
}

PatchCoverage locate_samples(const PatchField& field, const GridPatches& g, const PatchSamples& samples,
                             const std::atomic<bool>* cancel, int32_t first_patch) {
  validate(field, samples);
  const int32_t n = g.size, np = g.count, c = n / 2;
  if (n < 2 || g.points.size() != size_t(np) * size_t(n) * size_t(n))
    throw std::invalid_argument("locate samples: grid patches are inconsistent");
  if (first_patch < 0 || first_patch > np) throw std::invalid_argument("locate samples: first patch out of range");
  auto point = [&](int32_t p, int32_t i, int32_t j) {
    return v3(&g.positions[3 * ((size_t(p) * n + size_t(j)) * n + size_t(i))]);
  };
  auto valid = [&](int32_t p, int32_t i, int32_t j) {
    return g.points[(size_t(p) * n + size_t(j)) * n + size_t(i)].triangle >= 0;
  };
  // Per patch: centre, frame (one step along x and y) and bounding radius.
  struct Frame {
    V3 centre, ex, ey;
    double ex2 = 0, ey2 = 0, radius = -1;  // radius < 0: the patch is unusable
  };
  std::vector<Frame> frames(static_cast<size_t>(np));
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, np, 16), [&](const tbb::blocked_range<int32_t>& r) {
    for (int32_t p = r.begin(); p < r.end(); ++p) {
      Frame& f = frames[p];
      if (n < 3 || p < first_patch || !valid(p, c, c)) continue;
      f.centre = point(p, c, c);
      // One step along x and y from the centre, backwards where the forward point is lost (a boundary).
      if (valid(p, c + 1, c)) f.ex = point(p, c + 1, c) - f.centre;
      else if (valid(p, c - 1, c)) f.ex = f.centre - point(p, c - 1, c);
      else continue;
      if (valid(p, c, c + 1)) f.ey = point(p, c, c + 1) - f.centre;
      else if (valid(p, c, c - 1)) f.ey = f.centre - point(p, c, c - 1);
      else continue;
      f.ex2 = dot(f.ex, f.ex), f.ey2 = dot(f.ey, f.ey);
      double rad = 0;
      for (int32_t j = 0; j < n; ++j)
        for (int32_t i = 0; i < n; ++i)
          if (valid(p, i, j)) rad = std::max(rad, norm(point(p, i, j) - f.centre));
      f.radius = rad + std::sqrt(std::max(f.ex2, f.ey2));
    }
  });
  throw_if_cancelled(cancel);
  std::vector<double> radii;
  for (const Frame& f : frames)
    if (f.radius > 0) radii.push_back(f.radius);
  PatchCoverage out;
  out.sample_start.assign(size_t(samples.count) + 1, 0);
  out.patch_start.assign(size_t(np) + 1, 0);
  if (radii.empty()) {
    out.uncovered = samples.count;
    return out;
  }
  std::nth_element(radii.begin(), radii.begin() + radii.size() / 2, radii.end());
  const double cell = radii[radii.size() / 2];
  std::vector<std::pair<uint64_t, int32_t>> table;  // (cell key, patch), sorted
  for (int32_t p = 0; p < np; ++p) {
    const Frame& f = frames[p];
    int64_t lo[3], hi[3];
    if (f.radius < 0 || !spatial_cell(f.centre - V3{f.radius, f.radius, f.radius}, cell, lo) ||
        !spatial_cell(f.centre + V3{f.radius, f.radius, f.radius}, cell, hi))
      continue;
    for (int64_t x = lo[0]; x <= hi[0]; ++x)
      for (int64_t y = lo[1]; y <= hi[1]; ++y)
        for (int64_t z = lo[2]; z <= hi[2]; ++z) table.push_back({spatial_cell_key(x, y, z), p});
  }
  tbb::parallel_sort(table.begin(), table.end());
  throw_if_cancelled(cancel);

  // Samples in fixed chunks, each into its own list: concatenated in order, the same for any threads.
  struct Entry {
    int32_t sample, patch;
    float u, v;
  };
  constexpr int32_t kChunk = 4096;
  const int32_t chunks = (samples.count + kChunk - 1) / kChunk;
  std::vector<std::vector<Entry>> found(static_cast<size_t>(chunks));
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, chunks, 1), [&](const tbb::blocked_range<int32_t>& r) {
    for (int32_t chunk = r.begin(); chunk < r.end(); ++chunk) {
      throw_if_cancelled(cancel);
      std::vector<Entry>& list = found[chunk];
      list.reserve(size_t(kChunk) * 4);  // about 3 patches per sample when sampling
      // Neighbouring samples (texels of a row, vertices of a strip) mostly share a cell: its range of
      // the table is looked up once for them.
      uint64_t last_key = ~uint64_t(0);
      auto first = table.end();
      for (int32_t s = chunk * kChunk; s < std::min(samples.count, (chunk + 1) * kChunk); ++s) {
        const V3 x = v3(samples.positions + 3 * size_t(s));
        const V3 normal = samples.normals ? v3(samples.normals + 3 * size_t(s)) : V3{};
        int64_t k[3];
        if (!spatial_cell(x, cell, k)) continue;
        const uint64_t key = spatial_cell_key(k[0], k[1], k[2]);
        if (key != last_key) {
          first = std::lower_bound(table.begin(), table.end(), std::make_pair(key, int32_t(-1)));
          last_key = key;
        }
        for (auto it = first; it != table.end() && it->first == key; ++it) {
          const int32_t p = it->second;
          const Frame& f = frames[p];
          const V3 d = x - f.centre;
          if (norm(d) > f.radius) continue;
          const double gu = c + dot(d, f.ex) / f.ex2, gv = c + dot(d, f.ey) / f.ey2;
          if (gu < -3 || gv < -3 || gu > n + 2 || gv > n + 2) continue;
          int32_t i = std::clamp(int32_t(std::floor(gu)), 0, n - 2), j = std::clamp(int32_t(std::floor(gv)), 0, n - 2);
          // A sample on the last row of valid cells (next to a boundary) may be guessed into the invalid
          // cell beyond it: start from the nearest valid cell around the guess instead.
          if (!g.cell_valid[(size_t(p) * (n - 1) + size_t(j)) * (n - 1) + size_t(i)]) {
            const int32_t di = gu - std::floor(gu) < 0.5 ? -1 : 1, dj = gv - std::floor(gv) < 0.5 ? -1 : 1;
            for (auto [a, b] : {std::pair{i + di, j}, std::pair{i, j + dj}, std::pair{i + di, j + dj}})
              if (a >= 0 && b >= 0 && a <= n - 2 && b <= n - 2 &&
                  g.cell_valid[(size_t(p) * (n - 1) + size_t(b)) * (n - 1) + size_t(a)]) {
                i = a, j = b;
                break;
              }
          }
          for (int step = 0; step < kMaxWalk; ++step) {
            if (!g.cell_valid[(size_t(p) * (n - 1) + size_t(j)) * (n - 1) + size_t(i)]) break;
            const V3 p00 = point(p, i, j), p10 = point(p, i + 1, j), p11 = point(p, i + 1, j + 1),
                     p01 = point(p, i, j + 1);
            const CellCoordinates cc = cell_coordinates(p00, p10, p11, p01, x);
            if (!cc.ok) break;
            const int di = cc.s < -kCellSlack ? -1 : cc.s > 1 + kCellSlack ? 1 : 0;
            const int dj = cc.t < -kCellSlack ? -1 : cc.t > 1 + kCellSlack ? 1 : 0;
            if (di == 0 && dj == 0) {
              const double h = 0.5 * (norm(p10 - p00) + norm(p01 - p00));
              const V3 cell_normal = normalized_or(cross(p11 - p00, p01 - p10), V3{});
              const bool facing = !samples.normals || dot(cell_normal, normal) > kMinNormalDot;
              if (cc.distance < kMaxPlaneDistance * h && facing)
                list.push_back({s, p, float(i + std::clamp(cc.s, 0.0, 1.0)), float(j + std::clamp(cc.t, 0.0, 1.0))});
              break;
            }
            if (i + di < 0 || i + di > n - 2 || j + dj < 0 || j + dj > n - 2) break;
            i += di, j += dj;
          }
        }
        // Patches were met in ascending order per cell key, which is one key: already ascending.
      }
    }
  });
  throw_if_cancelled(cancel);
  int64_t total = 0;
  for (const auto& list : found) total += int64_t(list.size());
  out.sample_patch.resize(size_t(total));
  out.sample_uv.resize(2 * size_t(total));
  int64_t at = 0;
  for (const auto& list : found)
    for (const Entry& e : list) {
      out.sample_start[size_t(e.sample) + 1]++;
      out.patch_start[size_t(e.patch) + 1]++;
      out.sample_patch[at] = e.patch;
      out.sample_uv[2 * at] = e.u, out.sample_uv[2 * at + 1] = e.v;
      ++at;
    }
  for (int32_t s = 0; s < samples.count; ++s) {
    out.uncovered += out.sample_start[size_t(s) + 1] == 0;
    out.sample_start[size_t(s) + 1] += out.sample_start[s];
  }
  fill_patch_side(out, np);
  return out;
}

}  // namespace texsynth
