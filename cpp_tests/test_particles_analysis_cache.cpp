// SPDX-License-Identifier: GPL-3.0-or-later
// Particle analysis cache (particles/analysis_cache.hpp): every field round-trips, another key or a
// missing file gives nothing, truncated / flipped / lying files are refused with CacheError.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "temp_dir.hpp"
#include "texsynth/common/errors.hpp"
#include "texsynth/common/rng.hpp"
#include "texsynth/particles/analysis_cache.hpp"

namespace {

using texsynth::ParticleAnalysis;

// Two classes of discs in a grid on a noisy ground (close enough to co-occur); the last column
// crosses the right border (joined to the first when tileable; then analysed with the touching split too).
ParticleAnalysis analysed(bool tileable) {
  const int W = 96, H = 80;
  std::vector<float> px(size_t(W) * H * 3);
  texsynth::Rng rng(4);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      float c[3] = {0.2f, 0.3f, 0.25f};
      for (int j = 0; j < 4; ++j)
        for (int i = 0; i < 6; ++i) {
          const double cx = 10 + 17 * i, cy = 10 + 19 * j, dx = std::fabs(x + 0.5 - cx);
          if (std::hypot(tileable ? std::min(dx, W - dx) : dx, y + 0.5 - cy) > 5.5) continue;
          const bool odd = (i + j) % 2;
          c[0] = odd ? 0.9f : 0.8f, c[1] = odd ? 0.2f : 0.7f, c[2] = odd ? 0.1f : 0.3f;
        }
      for (int k = 0; k < 3; ++k) px[(size_t(y) * W + x) * 3 + k] = c[k] + float(0.02 * (rng.uniform() - 0.5));
    }
  texsynth::ParticleAnalysisParams p;
  p.classes = 3;
  p.tileable = tileable;
  p.touching = tileable;  // the tiled case also carries the touching flag
  p.seed = 3;
  return texsynth::analyse_particles({px.data(), W, H, 3}, p);
}

void expect_same(const ParticleAnalysis& a, const ParticleAnalysis& b) {
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  EXPECT_EQ(a.channels, b.channels);
  EXPECT_EQ(a.tileable, b.tileable);
  EXPECT_EQ(a.touching, b.touching);
  EXPECT_EQ(a.num_classes, b.num_classes);
  EXPECT_EQ(a.background, b.background);
  EXPECT_EQ(a.min_area, b.min_area);
  EXPECT_EQ(a.centres, b.centres);
  EXPECT_EQ(a.labels, b.labels);
  EXPECT_EQ(a.components, b.components);
  EXPECT_EQ(a.unwrapped, b.unwrapped);
  ASSERT_EQ(a.particles.size(), b.particles.size());
  for (size_t i = 0; i < a.particles.size(); ++i) {
    const texsynth::Particle &p = a.particles[i], &q = b.particles[i];
    EXPECT_TRUE(p.id == q.id && p.class_id == q.class_id && p.area == q.area && p.centroid_x == q.centroid_x &&
                p.centroid_y == q.centroid_y && p.x0 == q.x0 && p.y0 == q.y0 && p.x1 == q.x1 && p.y1 == q.y1 &&
                p.box.cx == q.box.cx && p.box.cy == q.box.cy && p.box.angle == q.box.angle &&
                p.box.half_x == q.box.half_x && p.box.half_y == q.box.half_y &&
                p.boundary_pixels == q.boundary_pixels && p.border_pixels == q.border_pixels &&
                p.complete == q.complete)
        << "particle " << i;
  }
  EXPECT_EQ(a.pixel_start, b.pixel_start);
  EXPECT_EQ(a.pixel_xy, b.pixel_xy);
  EXPECT_EQ(a.cooc_start, b.cooc_start);
  ASSERT_EQ(a.cooc.size(), b.cooc.size());
  for (size_t i = 0; i < a.cooc.size(); ++i) {
    const texsynth::CoOccurrence &p = a.cooc[i], &q = b.cooc[i];
    EXPECT_TRUE(p.quadrant == q.quadrant && p.dx == q.dx && p.dy == q.dy && p.angle == q.angle &&
                p.neighbour == q.neighbour && p.source == q.source)
        << "entry " << i;
  }
  ASSERT_EQ(a.classes.size(), b.classes.size());
  for (size_t i = 0; i < a.classes.size(); ++i) {
    const texsynth::ParticleClass &p = a.classes[i], &q = b.classes[i];
    EXPECT_TRUE(p.pixels == q.pixels && p.particles == q.particles && p.complete == q.complete &&
                p.colour == q.colour && p.background == q.background && p.has_complete == q.has_complete &&
                p.random == q.random && p.density == q.density && p.min_distance == q.min_distance &&
                p.tolerance == q.tolerance)
        << "class " << i;
  }
  ASSERT_EQ(a.class_pairs.size(), b.class_pairs.size());
  for (size_t i = 0; i < a.class_pairs.size(); ++i) {
    const texsynth::ParticleClassPair &p = a.class_pairs[i], &q = b.class_pairs[i];
    EXPECT_TRUE(p.pairs == q.pairs && p.tolerance == q.tolerance && p.margin == q.margin) << "class pair " << i;
  }
  EXPECT_EQ(a.background_fill, b.background_fill);
  EXPECT_EQ(a.merged_small, b.merged_small);
  EXPECT_EQ(a.merged_over_cap, b.merged_over_cap);
  EXPECT_EQ(a.classes_without_complete, b.classes_without_complete);
  EXPECT_EQ(a.stats.seconds_blur, b.stats.seconds_blur);
  EXPECT_EQ(a.stats.seconds_kmeans, b.stats.seconds_kmeans);
  EXPECT_EQ(a.stats.seconds_components, b.stats.seconds_components);
  EXPECT_EQ(a.stats.seconds_geometry, b.stats.seconds_geometry);
  EXPECT_EQ(a.stats.seconds_cooccurrence, b.stats.seconds_cooccurrence);
  EXPECT_EQ(a.stats.seconds_background, b.stats.seconds_background);
  EXPECT_EQ(a.stats.seconds_total, b.stats.seconds_total);
}

std::vector<uint8_t> read_all(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), {});
}
void write_all(const std::string& path, const std::vector<uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

TEST(ParticlesCache, EveryFieldRoundTrips) {
  texsynth_test::TempDir dir;
  for (bool tileable : {false, true}) {
    const ParticleAnalysis a = analysed(tileable);
    ASSERT_GE(a.particles.size(), 4u);
    ASSERT_FALSE(a.cooc.empty());
    ASSERT_EQ(a.touching, tileable);
    if (tileable) {
      ASSERT_FALSE(a.unwrapped.empty());
    }
    const std::string path = dir.file(tileable ? "tiled.tspart" : "plain.tspart");
    texsynth::save_particle_analysis(a, path, 0x1234);
    const auto b = texsynth::load_particle_analysis(path, 0x1234);
    ASSERT_TRUE(b.has_value());
    expect_same(a, *b);
  }
}

TEST(ParticlesCache, MissingFileOrAnotherKeyGivesNothing) {
  texsynth_test::TempDir dir;
  EXPECT_FALSE(texsynth::load_particle_analysis(dir.file("absent.tspart"), 1).has_value());
  const std::string path = dir.file("a.tspart");
  texsynth::save_particle_analysis(analysed(false), path, 77);
  EXPECT_FALSE(texsynth::load_particle_analysis(path, 78).has_value());
  EXPECT_TRUE(texsynth::load_particle_analysis(path, 77).has_value());
}

TEST(ParticlesCache, TruncatedFlippedAndLyingFilesAreRefused) {
  texsynth_test::TempDir dir;
  const std::string path = dir.file("a.tspart");
  texsynth::save_particle_analysis(analysed(true), path, 5);
  const std::vector<uint8_t> good = read_all(path);
  // Truncated anywhere: header, an array, the checksum.
  for (size_t keep : {size_t(0), size_t(10), size_t(27), good.size() / 2, good.size() - 1}) {
    write_all(path, std::vector<uint8_t>(good.begin(), good.begin() + std::ptrdiff_t(keep)));
    EXPECT_THROW(texsynth::load_particle_analysis(path, 5), texsynth::CacheError) << keep << " bytes";
  }
  // One flipped bit past the key, anywhere.
  texsynth::Rng rng(8);
  for (int k = 0; k < 40; ++k) {
    std::vector<uint8_t> bad = good;
    bad[20 + rng.below(uint32_t(bad.size() - 20))] ^= uint8_t(1u << rng.below(8));
    write_all(path, bad);
    EXPECT_THROW(texsynth::load_particle_analysis(path, 5), texsynth::CacheError);
  }
  // A lying length with a valid checksum: the first array's count claims more than the file holds.
  std::vector<uint8_t> lying(good.begin(), good.end() - 8);
  const size_t centres_count_at = 20 + 3 * 4 + 1 + 3 * 4;
  const uint64_t huge = uint64_t(1) << 60;
  std::memcpy(lying.data() + centres_count_at, &huge, 8);
  const uint64_t sum = texsynth::particle_cache_checksum(lying.data(), lying.size());
  lying.resize(lying.size() + 8);
  std::memcpy(lying.data() + lying.size() - 8, &sum, 8);
  write_all(path, lying);
  try {
    texsynth::load_particle_analysis(path, 5);
    ADD_FAILURE() << "a lying length was accepted";
  } catch (const texsynth::CacheError& e) {
    EXPECT_NE(std::string(e.what()).find("truncated"), std::string::npos) << e.what();
  }
  // A consistent-looking file whose labels point past the class table.
  ParticleAnalysis a = analysed(false);
  a.labels[7] = a.num_classes;
  const std::vector<uint8_t> forged = texsynth::serialize_particle_analysis(a, 5);
  EXPECT_THROW(texsynth::deserialize_particle_analysis(forged.data(), forged.size(), 5), texsynth::CacheError);
  // A class pair table of the wrong size, or with a negative margin (placement indexes it by class).
  for (int how : {0, 1}) {
    ParticleAnalysis c = analysed(false);
    if (how == 0) c.class_pairs.pop_back();
    else c.class_pairs[1].margin = -1;
    const std::vector<uint8_t> bytes = texsynth::serialize_particle_analysis(c, 5);
    EXPECT_THROW(texsynth::deserialize_particle_analysis(bytes.data(), bytes.size(), 5), texsynth::CacheError) << how;
  }
  // Not a cache at all.
  write_all(path, std::vector<uint8_t>(200, 'x'));
  EXPECT_THROW(texsynth::load_particle_analysis(path, 5), texsynth::CacheError);
}

}  // namespace
