// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/preprocess/preprocess.hpp"

#include <chrono>
#include <ctime>
#include <cmath>
#include <filesystem>
#include <stdexcept>
#include <string>

#include "texsynth/common/errors.hpp"
#include "texsynth/common/rng.hpp"
#include "texsynth/preprocess/cache.hpp"
#include "texsynth/preprocess/features.hpp"
#include "texsynth/preprocess/jump_map.hpp"
#include "texsynth/preprocess/kmeans.hpp"
#include "texsynth/preprocess/working_image.hpp"

namespace texsynth {

int resolved_num_textons(const PreprocessParams& params, int64_t pixel_count) {
  if (params.num_textons > 0) return params.num_textons;
  return int(std::max<int64_t>(1, std::llround(std::sqrt(double(pixel_count)))));
}

void validate_preprocess(const PreprocessParams& params, int width, int height) {
  auto bad = [](const std::string& what) { throw std::invalid_argument(what); };
  const int n = params.neighbourhood;
  if (n < 3 || n % 2 == 0 || n > kMaxNeighbourhood)
    bad("neighbourhood must be an odd number between 3 and " + std::to_string(kMaxNeighbourhood) + ", got " +
        std::to_string(n));
  if (params.working_size != 0 && (params.working_size < kMinWorkingSize || params.working_size > kMaxWorkingSize))
    bad("working_size must be 0 (the sample's own resolution) or between " + std::to_string(kMinWorkingSize) +
        " and " + std::to_string(kMaxWorkingSize) + ", got " + std::to_string(params.working_size));
  const std::string given = std::to_string(width) + "x" + std::to_string(height);
  if (int64_t(width) * height > kMaxSamplePixels)
    bad("sample " + given + " exceeds the limit of 8192x8192 pixels (its RGBA floats alone need " +
        std::to_string(int64_t(double(width) * double(height) * 16.0 / 1e6)) +  // double: sizes read from a damaged cache overflow int64
        " MB); downscale the sample");
  const Size2 analysed = working_dimensions(width, height, params.working_size);
  const int64_t pixels = int64_t(analysed.width) * analysed.height;
  if (pixels > kMaxImagePixels)
    bad("sample " + given + " exceeds the pixel limit (4096x4096) for analysis at its own resolution (about " +
        std::to_string(pixels * 100 / 1000000) + " MB); set a working size of at most 4096");
  width = analysed.width;
  height = analysed.height;
  if (width < n || height < n)
    bad("sample " + std::to_string(width) + "x" + std::to_string(height) + " is smaller than the " +
        std::to_string(n) + "x" + std::to_string(n) + " neighbourhood");
  if (params.num_textons < 0) bad("num_textons must be >= 0 (0 = automatic), got " + std::to_string(params.num_textons));
  const int k = resolved_num_textons(params, pixels);
  if (k > pixels)
    bad("num_textons " + std::to_string(k) + " exceeds the sample's pixel count " + std::to_string(pixels));
  if (k > kMaxTextons) bad("num_textons " + std::to_string(k) + " exceeds the limit " + std::to_string(kMaxTextons));
  if (params.jump_candidates < 1 || params.jump_candidates > kMaxJumpCandidates)
    bad("jump_candidates must be between 1 and " + std::to_string(kMaxJumpCandidates) + ", got " +
        std::to_string(params.jump_candidates));
  if (params.feature_dims < 0 || params.feature_dims > kMaxFeatureDims)
    bad("feature_dims must be between 0 (full) and " + std::to_string(kMaxFeatureDims) + ", got " +
        std::to_string(params.feature_dims));
  if (!(params.kmeans_change_fraction >= 0.0 && params.kmeans_change_fraction <= 1.0))
    bad("kmeans_change_fraction must be within [0, 1]");
  if (params.kmeans_max_iterations < 1 || params.kmeans_max_iterations > 10000)
    bad("kmeans_max_iterations must be between 1 and 10000");
}

Preprocessed preprocess(const Image& image, const PreprocessParams& params, const std::atomic<bool>* cancel,
                        PreprocessStats* stats, const PreprocessVariant& variant) {
  validate_image(image, kMaxSamplePixels);
  validate_preprocess(params, image.width, image.height);
  PreprocessStats local_stats;
  if (!stats) stats = &local_stats;
  auto clock = std::chrono::steady_clock::now();
  std::clock_t cpu_clock = std::clock();
  auto lap = [&](double& wall, double& cpu) {
    const auto now = std::chrono::steady_clock::now();
    const std::clock_t cpu_now = std::clock();
    wall = std::chrono::duration<double>(now - clock).count();
    cpu = double(cpu_now - cpu_clock) / CLOCKS_PER_SEC;
    clock = now;
    cpu_clock = cpu_now;
  };
  const uint64_t sample_hash = image_hash(image);
  // The analysis copy only when the sample is larger than the working size: otherwise no copy at all.
  const Size2 analysed = working_dimensions(image.width, image.height, params.working_size);
  std::optional<Image> scaled;
  if (analysed.width != image.width || analysed.height != image.height)
    scaled = working_image(image, params.working_size, cancel);
  const Image& work = scaled ? *scaled : image;
  lap(stats->working_seconds, stats->working_cpu);

  const int k = resolved_num_textons(params, work.pixel_count());
  const int full_dims = full_feature_dims(work, params.neighbourhood);
  const int dims = params.feature_dims > 0 && params.feature_dims < full_dims ? params.feature_dims : full_dims;
  if (double(work.pixel_count()) * dims > double(kMaxFeatureValues))
    throw std::invalid_argument("features of " + std::to_string(dims) + " dimensions for " +
                                std::to_string(work.pixel_count()) +
                                " pixels exceed the memory limit (1 GB); use fewer feature_dims or a smaller sample");

  const Features features =
      compute_features(work, params.neighbourhood, params.feature_dims, params.tileable, params.seed, cancel);
  if (cancel && cancel->load()) throw Cancelled();
  lap(stats->features_seconds, stats->features_cpu);

  KMeansParams km;
  km.num_clusters = k;
  km.seed = params.seed;
  km.change_fraction = params.kmeans_change_fraction;
  km.max_iterations = params.kmeans_max_iterations;
  km.full_lloyd = variant.full_lloyd;
  KMeansResult clusters = kmeans(features, km, cancel);
  stats->kmeans_full_iterations = clusters.iterations;
  stats->kmeans_subsample_iterations = clusters.subsample_iterations;
  stats->kmeans_last_change = clusters.last_change_fraction;
  lap(stats->kmeans_seconds, stats->kmeans_cpu);

  Preprocessed out;
  out.width = work.width;
  out.height = work.height;
  out.sample_width = image.width;
  out.sample_height = image.height;
  out.params = params;
  out.sample_hash = sample_hash;
  out.num_textons = k;
  out.texton_dims = features.dims;
  out.texton_map = std::move(clusters.labels);
  out.textons = std::move(clusters.centres);
  out.texton_distances = centre_distance_table(out.textons, k, out.texton_dims);
  build_buckets(out.texton_map, k, out.bucket_start, out.bucket_pixels);

  JumpSearchParams jp;
  jp.k = params.jump_candidates;
  jp.neighbourhood = params.neighbourhood;
  jp.tileable = params.tileable;
  jp.seed = params.seed;
  const CentreIndex index = build_centre_index(out.texton_distances, k, std::min(k, 64));
  lap(stats->tables_seconds, stats->tables_cpu);
  out.jump_map = build_jump_map(features, out.width, out.height, out.texton_map, out.bucket_start, out.bucket_pixels,
                                index, jp, cancel);
  lap(stats->jump_map_seconds, stats->jump_map_cpu);
  return out;
}

Preprocessed preprocess_cached(const Image& image, const PreprocessParams& params, const std::string& cache_dir,
                               const std::atomic<bool>* cancel) {
  validate_image(image, kMaxSamplePixels);
  validate_preprocess(params, image.width, image.height);
  if (cache_dir.empty()) throw std::invalid_argument("cache_dir is empty");
  const uint64_t hash = image_hash(image);
  const std::string path = cache_file_path(cache_dir, hash, params);
  std::string status = "miss";
  std::error_code ec;
  if (std::filesystem::exists(path, ec)) {
    try {
      Preprocessed cached = load_preprocessed(path, hash);
      if (same_params(cached.params, params)) {  // not just the file name's 32-bit hash
        cached.cache_hit = true;
        cached.cache_status = "hit";
        return cached;
      }
    } catch (const CacheError&) {
    }
    status = "recomputed-corrupt";
  }
  Preprocessed result = preprocess(image, params, cancel);
  std::filesystem::create_directories(cache_dir, ec);
  if (ec) throw std::runtime_error("cannot create cache directory '" + cache_dir + "': " + ec.message());
  save_preprocessed(result, path);
  result.cache_hit = false;
  result.cache_status = status;
  return result;
}

std::vector<uint8_t> texton_map_colors(const Preprocessed& result) {
  std::vector<uint8_t> rgb(result.texton_map.size() * 3);
  for (size_t p = 0; p < result.texton_map.size(); ++p) {
    // Distinct, fairly bright pseudo-colour per label; stable across runs.
    const uint64_t h = splitmix64(uint64_t(result.texton_map[p]) + 0x7465787465ull);
    for (int c = 0; c < 3; ++c) rgb[p * 3 + c] = uint8_t(48 + ((h >> (16 * c)) & 0xFF) * 207 / 255);
  }
  return rgb;
}

}  // namespace texsynth
