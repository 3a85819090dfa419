// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Preprocesses a sample with TBB limited to 1 and then 2 threads and expects the same bytes.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "texsynth/preprocess/preprocess.hpp"

namespace texsynth_test {

inline texsynth::Preprocessed expect_same_at_one_and_two_threads(const texsynth::Image& image,
                                                                 const texsynth::PreprocessParams& params) {
  texsynth::Preprocessed one, two;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    one = texsynth::preprocess(image, params);
  }
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
    two = texsynth::preprocess(image, params);
  }
  EXPECT_EQ(one.texton_map, two.texton_map);
  EXPECT_EQ(one.textons, two.textons);
  EXPECT_EQ(one.jump_map.targets, two.jump_map.targets);
  EXPECT_EQ(one.jump_map.weights, two.jump_map.weights);
  return one;
}

}  // namespace texsynth_test
