// SPDX-License-Identifier: GPL-3.0-or-later
// Texton strings, voting + top-m + Eq. 2 search against planted answers and brute force.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <set>

#include "texton_fixtures.hpp"
#include "texsynth/common/rng.hpp"
#include "texsynth/synth/texton_synth.hpp"

namespace {

using texsynth::OriginRange;
using texsynth::TextonString;

// Every integer origin keeping offsets o + phase inside [0, W] x [0, H] (independent of the synthesizer).
OriginRange fitting_range(const texsynth::Preprocessed& pre, const float (*o)[2], int n, const float phase[2]) {
  float lo[2] = {0, 0}, hi[2] = {0, 0};
  for (int i = 0; i < n; ++i)
    for (int a = 0; a < 2; ++a) lo[a] = std::min(lo[a], o[i][a]), hi[a] = std::max(hi[a], o[i][a]);
  OriginRange r;
  r.x0 = int(std::ceil(-lo[0] - phase[0])), r.x1 = int(std::floor(pre.width - hi[0] - phase[0]));
  r.y0 = int(std::ceil(-lo[1] - phase[1])), r.y1 = int(std::floor(pre.height - hi[1] - phase[1]));
  return r;
}

TEST(TextonSearch, PlantedNeighbourGivesTheExactContinuingOffset) {
  const auto pre = fixtures::label_sample(64, 64, 40, false, 21);
  texsynth::TextonSearch search(pre);
  const float face[3][2] = {{0.f, 0.f}, {9.3f, 1.2f}, {3.1f, 8.7f}};
  texsynth::Rng rng(77);
  for (int trial = 0; trial < 50; ++trial) {
    // The neighbour continues the planted origin G across edge 1 -> 2 (and, half the time, 2 -> 0).
    const float G[2] = {float(5 + 40 * rng.uniform()), float(5 + 40 * rng.uniform())};
    const float phase[2] = {G[0] - std::floor(G[0]), G[1] - std::floor(G[1])};
    TextonString s;
    auto add_edge = [&](int a, int b) {
      const float ta[2] = {G[0] + face[a][0], G[1] + face[a][1]}, tb[2] = {G[0] + face[b][0], G[1] + face[b][1]};
      texsynth::append_edge_string(pre, face[a], face[b], ta, tb, phase, s);
    };
    add_edge(1, 2);
    if (trial % 2) add_edge(2, 0);
    EXPECT_GE(s.size(), 9u);
    int32_t x = -100, y = -100;
    double err = -1;
    ASSERT_TRUE(search.search(s, fitting_range(pre, face, 3, phase), {}, 1234 + trial, x, y, err));
    EXPECT_EQ(x, int(std::floor(G[0]))) << trial;
    EXPECT_EQ(y, int(std::floor(G[1]))) << trial;
    EXPECT_EQ(err, 0.0);
  }
}

TEST(TextonSearch, LabelsAreReadAtTheNeighboursTexels) {
  const auto pre = fixtures::label_sample(32, 32, 7, false, 3);
  const float oa[2] = {0.f, 0.f}, ob[2] = {10.f, 0.f}, ta[2] = {4.f, 20.f}, tb[2] = {4.f, 10.f};  // rotated neighbour
  const float phase[2] = {0.25f, 0.5f};
  TextonString s;
  texsynth::append_edge_string(pre, oa, ob, ta, tb, phase, s);
  ASSERT_EQ(s.size(), 10u);
  for (int i = 0; i < 10; ++i) {
    const double t = (i + 0.5) / 10;
    EXPECT_EQ(s.label[i], pre.texton_map[size_t(std::floor(20 - 10 * t)) * 32 + 4]);
    EXPECT_EQ(s.dx[i], int(std::floor(0.25 + 10 * t)));
    EXPECT_EQ(s.dy[i], 0);
  }
}

double brute_error(const texsynth::Preprocessed& pre, const TextonString& s, int x, int y) {
  double e = 0;
  for (size_t k = 0; k < s.size(); ++k) {
    int px = x + s.dx[k], py = y + s.dy[k];
    px = ((px % pre.width) + pre.width) % pre.width, py = ((py % pre.height) + pre.height) % pre.height;
    e += pre.texton_distances[size_t(pre.texton_map[size_t(py) * pre.width + px]) * pre.num_textons + s.label[k]];
  }
  return e;
}

// With m covering every voted origin and the full string voting, voting + Eq. 2 returns the global
// Eq. 2 minimum whenever that minimum has at least one exact match (E* < length · min off-diagonal
// distance guarantees it: an origin without matches costs at least that much).
void expect_brute_force_minimum(bool tileable) {
  texsynth::Rng rng(tileable ? 8 : 9);
  int checked = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const auto pre = fixtures::label_sample(tileable ? 7 : 11, tileable ? 7 : 9, 4, tileable, 100 + trial);
    float min_off = std::numeric_limits<float>::infinity();
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b)
        if (a != b) min_off = std::min(min_off, pre.texton_distances[a * 4 + b]);
    TextonString s;
    const int len = 5 + int(rng.below(8));
    for (int k = 0; k < len; ++k) {
      s.label.push_back(int32_t(rng.below(4)));
      s.dx.push_back(int32_t(rng.below(5)));
      s.dy.push_back(int32_t(rng.below(4)));
    }
    OriginRange range;
    range.wrap = tileable;
    range.x0 = 0, range.y0 = 0;
    range.x1 = tileable ? pre.width - 1 : pre.width - 5, range.y1 = tileable ? pre.height - 1 : pre.height - 4;
    double best = std::numeric_limits<double>::infinity();
    for (int y = range.y0; y <= range.y1; ++y)
      for (int x = range.x0; x <= range.x1; ++x) best = std::min(best, brute_error(pre, s, x, y));
    texsynth::TextonSearch search(pre);
    int32_t x, y;
    double err;
    ASSERT_TRUE(search.search(s, range, {64, 255, 1 << 20, 0.0}, trial, x, y, err));
    EXPECT_TRUE(x >= range.x0 && x <= range.x1 && y >= range.y0 && y <= range.y1);
    EXPECT_NEAR(err, brute_error(pre, s, x, y), 1e-9);
    if (best < len * double(min_off)) {
      ++checked;
      EXPECT_NEAR(err, best, 1e-9) << "trial " << trial;
    }
  }
  EXPECT_GT(checked, 150);
}

TEST(TextonSearch, TopMWithEq2EqualsBruteForceMinimum) { expect_brute_force_minimum(false); }
TEST(TextonSearch, TopMWithEq2EqualsBruteForceMinimumTileable) { expect_brute_force_minimum(true); }

TEST(TextonSearch, NearTiesAreChosenAtRandom) {
  auto pre = fixtures::label_sample(40, 40, 1, false, 1);  // one texton: every origin ties
  texsynth::TextonSearch search(pre);
  TextonString s;
  for (int k = 0; k < 6; ++k) s.label.push_back(0), s.dx.push_back(k), s.dy.push_back(k);
  OriginRange range;
  range.x1 = 30, range.y1 = 30;
  std::set<std::pair<int, int>> seen;
  for (uint64_t seed = 0; seed < 40; ++seed) {
    int32_t x, y;
    double err;
    ASSERT_TRUE(search.search(s, range, {}, seed, x, y, err));
    seen.insert({x, y});
  }
  EXPECT_GT(seen.size(), 30u);
}

TEST(TextonSearch, NoVoteInsideTheRangeReturnsFalse) {
  auto pre = fixtures::label_sample(20, 20, 3, false, 2);
  texsynth::TextonSearch search(pre);
  TextonString s;
  s.label = {0}, s.dx = {100}, s.dy = {0};  // every vote lands at negative x
  OriginRange range;
  range.x1 = 19, range.y1 = 19;
  int32_t x, y;
  double err;
  EXPECT_FALSE(search.search(s, range, {}, 0, x, y, err));
}

}  // namespace

namespace {

// Coherent candidates: among a wrong origin and the planted continuation, the continuation
// (Eq. 2 = 0) is taken; with a threshold at 0 nothing is, and candidates outside the range are skipped.
TEST(TextonSearch, CoherentOriginTakesThePlantedContinuation) {
  const auto pre = fixtures::label_sample(64, 64, 40, false, 21);
  const float face[3][2] = {{0.f, 0.f}, {9.3f, 1.2f}, {3.1f, 8.7f}};
  const float G[2] = {20.4f, 17.8f};
  const float phase[2] = {G[0] - std::floor(G[0]), G[1] - std::floor(G[1])};
  TextonString s;
  const float ta[2] = {G[0] + face[1][0], G[1] + face[1][1]}, tb[2] = {G[0] + face[2][0], G[1] + face[2][1]};
  texsynth::append_edge_string(pre, face[1], face[2], ta, tb, phase, s);
  const OriginRange range = fitting_range(pre, face, 3, phase);
  const int32_t xy[6] = {31, 5, 20, 17, 1000, 17};  // wrong, planted, outside the range
  int32_t x = -1, y = -1;
  double err = -1;
  ASSERT_TRUE(texsynth::coherent_origin(pre, s, xy, 3, range, 0.5, x, y, err));
  EXPECT_EQ(x, 20);
  EXPECT_EQ(y, 17);
  EXPECT_EQ(err, 0.0);
  EXPECT_FALSE(texsynth::coherent_origin(pre, s, xy, 3, range, 0.0, x, y, err));  // strict: below the bound
  // Only the wrong one: its error (> 0.5 per point with this table) is refused under a tight bound.
  EXPECT_GT(texsynth::string_error(pre, s, 31, 5, false), 0.5);
  EXPECT_FALSE(texsynth::coherent_origin(pre, s, xy, 1, range, 0.5, x, y, err));
  EXPECT_FALSE(texsynth::coherent_origin(pre, s, xy + 4, 1, range, 1e9, x, y, err));  // outside the range
}

}  // namespace
