// SPDX-License-Identifier: GPL-3.0-or-later
// Analysis through a bounded working copy (PreprocessParams::working_size, issue 16).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "cancel_latency.hpp"
#include "preprocess_threads.hpp"
#include "synthetic_texture.hpp"
#include "temp_dir.hpp"
#include "texsynth/common/errors.hpp"
#include "texsynth/preprocess/cache.hpp"
#include "texsynth/preprocess/preprocess.hpp"
#include "texsynth/preprocess/working_image.hpp"

namespace {

std::string error_of(const texsynth::PreprocessParams& params, int width, int height) {
  try {
    texsynth::validate_preprocess(params, width, height);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(PreprocessWorking, DimensionsKeepTheAspectAndLeaveSmallSamplesAlone) {
  EXPECT_EQ(texsynth::working_dimensions(4096, 2048, 1024).width, 1024);
  EXPECT_EQ(texsynth::working_dimensions(4096, 2048, 1024).height, 512);
  EXPECT_EQ(texsynth::working_dimensions(1000, 3000, 600).width, 200);
  EXPECT_EQ(texsynth::working_dimensions(1000, 3000, 600).height, 600);
  EXPECT_EQ(texsynth::working_dimensions(800, 600, 1024).width, 800);
  EXPECT_EQ(texsynth::working_dimensions(8192, 8192, 0).width, 8192);
  EXPECT_EQ(texsynth::working_dimensions(8192, 1, 1024).height, 1);  // never 0
}

TEST(PreprocessWorking, AreaAverageIsExactForWholeAndFractionalFootprints) {
  // 4x2 -> 2x1: each output is the mean of a 2x2 block.
  const std::vector<float> a = {1, 2, 3, 4, 5, 6, 7, 8};
  const auto half = texsynth::area_downscale(a.data(), 4, 2, 1, 2, 1);
  ASSERT_EQ(half.size(), 2u);
  EXPECT_FLOAT_EQ(half[0], (1 + 2 + 5 + 6) / 4.0f);
  EXPECT_FLOAT_EQ(half[1], (3 + 4 + 7 + 8) / 4.0f);
  // 3 -> 2 columns: the middle pixel is shared half and half.
  const std::vector<float> b = {0, 3, 6};
  const auto two = texsynth::area_downscale(b.data(), 3, 1, 1, 2, 1);
  EXPECT_FLOAT_EQ(two[0], (0 * 1.0f + 3 * 0.5f) / 1.5f);
  EXPECT_FLOAT_EQ(two[1], (3 * 0.5f + 6 * 1.0f) / 1.5f);
  // Channels stay apart; a constant image stays constant.
  const std::vector<float> rgb(7 * 5 * 3, 0.25f);
  for (float v : texsynth::area_downscale(rgb.data(), 7, 5, 3, 3, 2)) EXPECT_FLOAT_EQ(v, 0.25f);
}

TEST(PreprocessWorking, LargeSampleIsAnalysedAtTheWorkingSizeDeterministically) {
  const texsynth::Image image = texsynth_test::gravel_texture(400, 300, 24.0f);
  texsynth::PreprocessParams params;
  params.working_size = 200;
  const texsynth::Preprocessed one = texsynth_test::expect_same_at_one_and_two_threads(image, params);
  EXPECT_EQ(one.width, 200);
  EXPECT_EQ(one.height, 150);
  EXPECT_EQ(one.sample_width, 400);
  EXPECT_EQ(one.sample_height, 300);
  EXPECT_EQ(one.sample_hash, texsynth::image_hash(image)) << "the cache is keyed by the sample as given";
  EXPECT_EQ(one.num_textons, texsynth::resolved_num_textons(params, 200 * 150));
  EXPECT_EQ(one.texton_map.size(), size_t(200 * 150));
  for (int32_t t : one.jump_map.targets) EXPECT_LT(t, 200 * 150);
}

TEST(PreprocessWorking, SampleThatFitsIsAnalysedAsItIs) {
  const texsynth::Image image = texsynth_test::brick_texture(96, 80, 2);
  texsynth::PreprocessParams fits, own;
  fits.working_size = 96;
  own.working_size = 0;
  const auto a = texsynth::preprocess(image, fits), b = texsynth::preprocess(image, own);
  EXPECT_EQ(a.width, 96);
  EXPECT_EQ(a.texton_map, b.texton_map);
  EXPECT_EQ(a.textons, b.textons);
  EXPECT_EQ(a.jump_map.targets, b.jump_map.targets);
  EXPECT_EQ(a.jump_map.weights, b.jump_map.weights);
}

TEST(PreprocessWorking, CacheKeepsTheWorkingSizeAndSampleSize) {
  const texsynth::Image image = texsynth_test::gravel_texture(260, 200, 20.0f);
  texsynth::PreprocessParams params;
  params.working_size = 128;
  texsynth_test::TempDir dir;
  const auto first = texsynth::preprocess_cached(image, params, dir.file("cache"));
  const auto second = texsynth::preprocess_cached(image, params, dir.file("cache"));
  EXPECT_EQ(second.cache_status, "hit");
  EXPECT_EQ(second.params.working_size, 128);
  EXPECT_EQ(second.width, first.width);
  EXPECT_EQ(second.sample_width, 260);
  EXPECT_EQ(second.sample_height, 200);
  EXPECT_EQ(second.jump_map.targets, first.jump_map.targets);
  texsynth::PreprocessParams other = params;
  other.working_size = 256;
  EXPECT_NE(texsynth::cache_file_path("c", 1, params), texsynth::cache_file_path("c", 1, other));
}

TEST(PreprocessWorking, HugeSamplesAreScaledOrRefusedWithTheMemoryTheyNeed) {
  texsynth::PreprocessParams params;  // working size 512
  EXPECT_EQ(error_of(params, 8192, 8192), "");
  EXPECT_EQ(error_of(params, 8192, 3000), "");
  const std::string huge = error_of(params, 16384, 16384);
  EXPECT_NE(huge.find("8192x8192"), std::string::npos) << huge;
  EXPECT_NE(huge.find("4294 MB"), std::string::npos) << huge;
  params.working_size = 0;
  const std::string own = error_of(params, 8192, 8192);
  EXPECT_NE(own.find("working size"), std::string::npos) << own;
  EXPECT_NE(own.find("MB"), std::string::npos) << own;
  EXPECT_EQ(error_of(params, 4096, 4096), "");
  for (int bad : {-1, 63, 4097}) {
    params.working_size = bad;
    EXPECT_NE(error_of(params, 512, 512).find("working_size must be"), std::string::npos) << bad;
  }
}

TEST(PreprocessWorking, CancelAnswersDuringTheScaleStage) {
  // A 4096² sample: the scale-down alone takes long enough to be caught mid-way.
  const texsynth::Image image = texsynth_test::gravel_texture(4096, 4096, 144.0f);
  texsynth::PreprocessParams params;
  const double cpu_ms = texsynth_test::least_cancel_work_cpu_ms([&] {
    std::atomic<bool> cancel{false};
    std::atomic<double> raised_cpu_ms{0.0};
    std::thread raiser([&] {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      raised_cpu_ms = texsynth_test::process_cpu_ms();
      cancel = true;
    });
    EXPECT_THROW(texsynth::preprocess(image, params, &cancel), texsynth::Cancelled);
    const double work = texsynth_test::process_cpu_ms() - raised_cpu_ms;
    raiser.join();
    std::printf("cancel answered after %.1f CPU-ms of work\n", work);
    return work;
  });
  EXPECT_LT(cpu_ms, texsynth_test::kCancelWorkCpuMs);
}

}  // namespace
