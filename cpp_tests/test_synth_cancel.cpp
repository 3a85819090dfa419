// SPDX-License-Identifier: GPL-3.0-or-later
// Cancellation: a raised flag makes every long stage (mesh build, orientation field, vertex order,
// jump-map and texton synthesis, preprocessing) throw texsynth::Cancelled instead of returning;
// raising it from another thread stops a running synthesis. (Latency is measured in python_tests/bench/bench_cancel.py.)
#include <gtest/gtest.h>

#include <atomic>
#include <future>
#include <thread>

#include "mesh_fixtures.hpp"
#include "synthetic_texture.hpp"
#include "texsynth/common/errors.hpp"
#include "texsynth/field/orientation_field.hpp"
#include "texsynth/mesh/mesh.hpp"
#include "texsynth/preprocess/preprocess.hpp"
#include "texsynth/synth/jumpmap_synth.hpp"
#include "texsynth/synth/texton_synth.hpp"

namespace {

using texsynth::Cancelled;

const texsynth::Image& small_image() {
  static const texsynth::Image image = texsynth_test::brick_texture(64, 64, 2);
  return image;
}

const texsynth::Preprocessed& small_sample() {
  static const texsynth::Preprocessed pre = [] {
    texsynth::PreprocessParams p;
    p.neighbourhood = 5;
    p.num_textons = 8;
    p.feature_dims = 8;
    return texsynth::preprocess(small_image(), p);
  }();
  return pre;
}

texsynth::SampleImage small_sample_pixels() {
  const texsynth::Image& image = small_image();
  return {image.pixels.data(), image.width, image.height, image.channels};
}

std::vector<float> up_field(const texsynth::Mesh& mesh) {
  texsynth::FieldParams f;
  f.axis = {0.f, 1.f, 0.f};
  return texsynth::compute_orientation_field(mesh, f);
}

// Runs synthesize(flag) on another thread and raises the flag 2 ms later: it must end in Cancelled.
template <class Synthesize>
void expect_stopped_mid_run(Synthesize&& synthesize) {
  std::atomic<bool> flag{false};
  auto running = std::async(std::launch::async, [&] { synthesize(&flag); });
  std::this_thread::sleep_for(std::chrono::milliseconds(2));
  flag.store(true);
  EXPECT_THROW(running.get(), Cancelled);
}

TEST(Cancel, RaisedFlagStopsEveryStage) {
  const auto grid = fixtures::grid(40, 40, 0.5, false);
  std::atomic<bool> raised{true};
  EXPECT_THROW(texsynth::build_mesh(grid.input(), nullptr, &raised), Cancelled);
  const texsynth::Mesh mesh = texsynth::build_mesh(grid.input());
  texsynth::FieldParams f;
  f.cancel = &raised;
  EXPECT_THROW(texsynth::compute_orientation_field(mesh, f), Cancelled);
  const std::vector<float> up = up_field(mesh);
  texsynth::JumpSynthParams p;
  p.scale = 2.0;
  p.cancel = &raised;
  EXPECT_THROW(texsynth::synthesize_jumpmap(small_sample(), mesh, up.data(), p), Cancelled);
  texsynth::PreprocessParams pp;
  pp.neighbourhood = 5;
  pp.num_textons = 4;
  EXPECT_THROW(texsynth::preprocess(texsynth_test::brick_texture(32, 32, 1), pp, &raised), Cancelled);
  // The same calls with the flag lowered complete: the flag, not the input, stopped them.
  std::atomic<bool> lowered{false};
  p.cancel = &lowered;
  EXPECT_EQ(texsynth::synthesize_jumpmap(small_sample(), mesh, up.data(), p).maps.num_corners, mesh.num_corners);
  EXPECT_EQ(texsynth::region_growing_order(mesh, 1, &lowered).order.size(), size_t(mesh.num_vertices));
}

TEST(Cancel, RaisedFlagStopsTextonSynthesis) {
  const auto grid = fixtures::grid(40, 40, 0.5, false);
  const texsynth::Mesh mesh = texsynth::build_mesh(grid.input());
  const std::vector<float> up = up_field(mesh);
  std::atomic<bool> raised{true}, lowered{false};
  texsynth::TextonSynthParams p;
  p.scale = 2.0;
  p.cancel = &raised;
  EXPECT_THROW(texsynth::synthesize_texton(small_sample(), mesh, up.data(), small_sample_pixels(), p), Cancelled);
  p.cancel = &lowered;
  EXPECT_EQ(texsynth::synthesize_texton(small_sample(), mesh, up.data(), small_sample_pixels(), p).maps.num_corners,
            mesh.num_corners);
}

TEST(Cancel, FlagRaisedFromAnotherThreadStopsARunningTextonSynthesis) {
  const auto grid = fixtures::grid(400, 400, 0.05, false);  // 160k quads: most of a second of searching
  const texsynth::Mesh mesh = texsynth::build_mesh(grid.input());
  const std::vector<float> up = up_field(mesh);
  expect_stopped_mid_run([&](const std::atomic<bool>* flag) {
    texsynth::TextonSynthParams p;
    p.scale = 2.0;
    p.cancel = flag;
    texsynth::synthesize_texton(small_sample(), mesh, up.data(), small_sample_pixels(), p);
  });
}

TEST(Cancel, OrderStopsOnLargeMeshes) {
  const auto grid = fixtures::grid(300, 300, 0.1, true);  // > 65536 vertices: the order checks the flag
  const texsynth::Mesh mesh = texsynth::build_mesh(grid.input());
  std::atomic<bool> raised{true};
  EXPECT_THROW(texsynth::region_growing_order(mesh, 1, &raised), Cancelled);
}

TEST(Cancel, FlagRaisedFromAnotherThreadStopsARunningSynthesis) {
  const auto grid = fixtures::grid(700, 700, 0.05, false);  // 490k quads: seconds of work
  const texsynth::Mesh mesh = texsynth::build_mesh(grid.input());
  const std::vector<float> up = up_field(mesh);
  expect_stopped_mid_run([&](const std::atomic<bool>* flag) {
    texsynth::JumpSynthParams p;
    p.scale = 2.0;
    p.cancel = flag;
    texsynth::synthesize_jumpmap(small_sample(), mesh, up.data(), p);
  });
}

}  // namespace
