// SPDX-License-Identifier: GPL-3.0-or-later
// Preprocessing entry point: raw pixels (any type, size, NaN/Inf) and every PreprocessParams field.
// Each input must end in std::invalid_argument or a consistent Preprocessed.
#include "fuzz_common.hpp"
#include "texsynth/preprocess/preprocess.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  FuzzedDataProvider in(data, size);
  const auto type = texsynth::PixelType(in.ConsumeIntegralInRange<int>(0, 3));
  const int width = in.ConsumeIntegralInRange<int>(-2, 24);
  const int height = in.ConsumeIntegralInRange<int>(-2, 24);
  const int channels = in.ConsumeIntegralInRange<int>(-1, 6);
  texsynth::PreprocessParams p;
  // Large windows only past the limit: a legal 25x25 window makes each input a slow eigen-solve.
  p.neighbourhood = in.ConsumeBool() ? in.ConsumeIntegralInRange<int>(-3, 9) : in.ConsumeIntegralInRange<int>(24, 27) + 2;
  p.num_textons = in.ConsumeBool() ? in.ConsumeIntegralInRange<int>(-5, 700) : in.ConsumeIntegral<int>();
  p.jump_candidates = in.ConsumeIntegralInRange<int>(-2, 40);
  p.feature_dims = in.ConsumeIntegralInRange<int>(-2, 3000);
  p.tileable = in.ConsumeBool();
  p.seed = in.ConsumeIntegral<uint64_t>();
  p.kmeans_change_fraction = fuzz::hostile_double(in, -0.5, 1.5);
  p.kmeans_max_iterations = in.ConsumeIntegralInRange<int>(-2, 60);
  const size_t bytes_per_value = type == texsynth::PixelType::kUint8 ? 1 : type == texsynth::PixelType::kFloat32 ? 4 : 2;
  const size_t values = size_t(std::max(width, 0)) * size_t(std::max(height, 0)) * size_t(std::max(channels, 0));
  std::vector<uint8_t> pixels = in.ConsumeBytes<uint8_t>(values * bytes_per_value);
  pixels.resize(values * bytes_per_value, 0x3c);  // pad: 0x3c3c is a finite half, 0x3c3c3c3c a finite float
  texsynth::Image image;
  try {
    image = texsynth::image_from_pixels(pixels.data(), type, width, height, channels);
  } catch (const std::invalid_argument&) {
    return 0;
  }
  texsynth::Preprocessed r;
  try {
    r = texsynth::preprocess(image, p);
  } catch (const std::invalid_argument&) {
    return 0;
  }
  const size_t n = size_t(width) * size_t(height);
  fuzz::require(r.width == width && r.height == height, "size kept");
  fuzz::require(r.num_textons >= 1 && size_t(r.num_textons) <= n, "1 <= K <= pixels");
  fuzz::require(r.texton_map.size() == n && r.bucket_pixels.size() == n, "per-pixel arrays sized");
  for (int32_t t : r.texton_map) fuzz::require(t >= 0 && t < r.num_textons, "texton label in range");
  for (float v : r.textons) fuzz::require(std::isfinite(v), "finite textons");
  fuzz::require(r.jump_map.targets.size() == n * size_t(p.jump_candidates), "jump map sized");
  for (size_t i = 0; i < r.jump_map.targets.size(); ++i) {
    const int32_t t = r.jump_map.targets[i];
    fuzz::require(t >= -1 && t < int64_t(n) && t != int64_t(i / size_t(p.jump_candidates)), "jump target valid");
    fuzz::require(r.jump_map.weights[i] >= 0.0f && r.jump_map.weights[i] <= 1.0f, "jump weight in [0, 1]");
  }
  return 0;
}
