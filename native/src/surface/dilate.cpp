// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/surface/dilate.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

#include "texsynth/common/errors.hpp"
#include "texsynth/surface/texel_samples.hpp"

namespace texsynth {
namespace {

void check_size(const char* what, int32_t width, int32_t height, int32_t margin) {
  if (width < 1 || height < 1)
    throw std::invalid_argument(std::string(what) + ": image size must be at least 1 x 1, got " + std::to_string(width) +
                                " x " + std::to_string(height));
  if (int64_t(width) * height > std::numeric_limits<int32_t>::max())
    throw std::invalid_argument(std::string(what) + ": a " + std::to_string(width) + " x " + std::to_string(height) +
                                " image has too many pixels to index");
  if (margin < 0 || margin > kMaxMarginTexels)
    throw std::invalid_argument(std::string(what) + ": margin must be in 0.." + std::to_string(kMaxMarginTexels) +
                                ", got " + std::to_string(margin));
}

// Bands of output rows in parallel. For the rows a band can reach (its own +- margin), the nearest
// covered column of every pixel in that row (ties: the left one, the lower index). A pixel's
// nearest covered pixel is then the best of those row candidates within margin: (2M+1) look-ups,
// done only where a running column count says some row in reach has a covered pixel within M
// columns (so far-away pixels cost O(1)). Bands append in row order: ascending, deterministic.
template <class Covered>
MarginPixels margin_pixels(Covered covered, int32_t width, int32_t height, int32_t margin,
                           const std::atomic<bool>* cancel) {
  MarginPixels out;
  if (margin == 0) return out;
  const int32_t W = width, H = height, M = margin;
  const int64_t M2 = int64_t(M) * M;
  const int32_t band = std::max<int32_t>(32, M);  // rows of reach per band stay <= 3x its own
  const int32_t num_bands = (H + band - 1) / band;
  std::vector<MarginPixels> parts(static_cast<size_t>(num_bands));
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, num_bands, 1), [&](const tbb::blocked_range<int32_t>& range) {
    std::vector<int32_t> nearest;  // rows [r0, r1) x W: nearest covered column in the row, -1 if none
    std::vector<int32_t> reach(static_cast<size_t>(W));
    for (int32_t b = range.begin(); b < range.end(); ++b) {
      throw_if_cancelled(cancel);
      const int32_t y0 = b * band, y1 = std::min(H, y0 + band);
      const int32_t r0 = std::max(0, y0 - M), r1 = std::min(H, y1 + M);
      nearest.resize(size_t(r1 - r0) * W);
      for (int32_t r = r0; r < r1; ++r) {
        int32_t* row = nearest.data() + size_t(r - r0) * W;
        const int64_t base = int64_t(r) * W;
        for (int32_t x = 0, last = -1; x < W; ++x) {
          if (covered(base + x)) last = x;
          row[x] = last;
        }
        for (int32_t x = W - 1, next = -1; x >= 0; --x) {
          if (covered(base + x)) next = x;
          if (next >= 0 && (row[x] < 0 || next - x < x - row[x])) row[x] = next;
        }
      }
      auto near_in_row = [&](int32_t r, int32_t x) {
        const int32_t c = nearest[size_t(r - r0) * W + x];
        return c >= 0 && std::abs(x - c) <= M;
      };
      // reach[x]: rows within +-M of y holding a covered pixel within M columns of x.
      std::fill(reach.begin(), reach.end(), 0);
      for (int32_t r = std::max(0, y0 - M); r <= std::min(H - 1, y0 + M); ++r)
        for (int32_t x = 0; x < W; ++x) reach[x] += near_in_row(r, x);
      MarginPixels& part = parts[b];
      for (int32_t y = y0; y < y1; ++y) {
        if (y > y0) {
          if (y + M < H)
            for (int32_t x = 0; x < W; ++x) reach[x] += near_in_row(y + M, x);
          if (y - M - 1 >= 0)
            for (int32_t x = 0; x < W; ++x) reach[x] -= near_in_row(y - M - 1, x);
        }
        for (int32_t x = 0; x < W; ++x) {
          if (reach[x] == 0 || covered(int64_t(y) * W + x)) continue;
          int64_t best_d2 = M2 + 1;
          int32_t best = -1;
          auto consider = [&](int32_t r, int32_t dy) {
            const int32_t c = nearest[size_t(r - r0) * W + x];
            if (c < 0) return;
            const int64_t d2 = int64_t(dy) * dy + int64_t(x - c) * (x - c);
            const int32_t index = r * W + c;
            if (d2 <= M2 && (d2 < best_d2 || (d2 == best_d2 && index < best))) best_d2 = d2, best = index;
          };
          consider(y, 0);
          for (int32_t dy = 1; dy <= M && int64_t(dy) * dy <= best_d2; ++dy) {  // outwards: stop once too far
            if (y - dy >= 0) consider(y - dy, dy);
            if (y + dy < H) consider(y + dy, dy);
          }
          if (best >= 0) {
            part.pixel.push_back(y * W + x);
            part.source.push_back(best);
          }
        }
      }
    }
  });
  throw_if_cancelled(cancel);
  size_t total = 0;
  for (const MarginPixels& p : parts) total += p.pixel.size();
  out.pixel.reserve(total);
  out.source.reserve(total);
  for (const MarginPixels& p : parts) {
    out.pixel.insert(out.pixel.end(), p.pixel.begin(), p.pixel.end());
    out.source.insert(out.source.end(), p.source.begin(), p.source.end());
  }
  return out;
}

}  // namespace

MarginPixels find_margin_pixels(const uint8_t* covered, int32_t width, int32_t height, int32_t margin,
                                const std::atomic<bool>* cancel) {
  check_size("find_margin_pixels", width, height, margin);
  if (!covered) throw std::invalid_argument("find_margin_pixels: missing coverage mask");
  return margin_pixels([covered](int64_t i) { return covered[i] != 0; }, width, height, margin, cancel);
}

MarginPixels find_margin_pixels(const int32_t* owner, int32_t width, int32_t height, int32_t margin,
                                const std::atomic<bool>* cancel) {
  check_size("find_margin_pixels", width, height, margin);
  if (!owner) throw std::invalid_argument("find_margin_pixels: missing owner table");
  return margin_pixels([owner](int64_t i) { return owner[i] >= 0; }, width, height, margin, cancel);
}

std::vector<float> dilate_margin(const float* image, const uint8_t* covered, int32_t width, int32_t height,
                                 int32_t channels, int32_t margin, const std::atomic<bool>* cancel) {
  check_size("dilate_margin", width, height, margin);
  if (channels < 1) throw std::invalid_argument("dilate_margin: channels must be >= 1, got " + std::to_string(channels));
  if (!image || !covered) throw std::invalid_argument("dilate_margin: missing image or coverage mask");
  const size_t C = size_t(channels);
  std::vector<float> out(image, image + size_t(width) * height * C);
  const MarginPixels m = find_margin_pixels(covered, width, height, margin, cancel);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, m.pixel.size(), 16384), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i < r.end(); ++i)
      std::memcpy(&out[size_t(m.pixel[i]) * C], image + size_t(m.source[i]) * C, C * sizeof(float));
  });
  return out;
}

}  // namespace texsynth
