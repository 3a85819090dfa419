// SPDX-License-Identifier: GPL-3.0-or-later
// Mesh and synthesis parameter entry points: build_mesh -> compute_orientation_field ->
// synthesize_jumpmap on arbitrary Blender-layout arrays (bad indices, NaN/1e30 positions, odd
// polygon sizes) and arbitrary field/synthesis parameters. Each stage must either throw
// std::invalid_argument or return complete, finite output.
#include "../synthetic_texture.hpp"
#include "fuzz_meshes.hpp"
#include "texsynth/field/orientation_field.hpp"
#include "texsynth/mesh/mesh.hpp"
#include "texsynth/preprocess/preprocess.hpp"
#include "texsynth/synth/jumpmap_synth.hpp"

namespace {

const texsynth::Preprocessed& sample() {
  static const texsynth::Preprocessed pre = [] {
    texsynth::PreprocessParams p;
    p.neighbourhood = 5;
    p.num_textons = 8;
    p.feature_dims = 8;
    return texsynth::preprocess(texsynth_test::brick_texture(48, 40, 3), p);
  }();
  return pre;
}

std::vector<int32_t> indices(FuzzedDataProvider& in, int32_t num_vertices, int max_count) {
  std::vector<int32_t> out(in.ConsumeIntegralInRange<int>(0, max_count));
  for (auto& v : out) v = in.ConsumeIntegralInRange<int32_t>(-2, num_vertices + 1);
  return out;
}

texsynth::Vec3f vec3(FuzzedDataProvider& in) {
  return {fuzz::hostile_float(in, -2, 2), fuzz::hostile_float(in, -2, 2), fuzz::hostile_float(in, -2, 2)};
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  sample();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  FuzzedDataProvider in(data, size);
  fuzz::FuzzMesh fuzz_mesh = fuzz::random_mesh(in, 48, 40);
  const int32_t nv = fuzz_mesh.num_vertices;
  std::vector<int32_t>& corners = fuzz_mesh.corners;
  if (in.ConsumeIntegralInRange<int>(0, 7) == 0) corners.resize(in.ConsumeIntegralInRange<size_t>(0, corners.size()));
  std::vector<float> normals;
  if (in.ConsumeIntegralInRange<int>(0, 3) == 0)
    for (int32_t i = 0; i < nv * 3; ++i) normals.push_back(fuzz::hostile_float(in, -1, 1));

  texsynth::FieldParams field;
  field.mode = texsynth::OrientationMode(in.ConsumeIntegralInRange<int>(0, 2));
  field.axis = vec3(in);
  std::vector<float> direction;
  if (in.ConsumeBool())
    for (int32_t i = 0; i < nv * 3; ++i) direction.push_back(fuzz::hostile_float(in, -1, 1));
  field.direction = direction.empty() ? nullptr : direction.data();
  field.anchor_vertices = indices(in, nv, 4);
  for (size_t i = 0; i < field.anchor_vertices.size(); ++i) field.anchor_directions.push_back(vec3(in));
  if (in.ConsumeIntegralInRange<int>(0, 7) == 0) field.anchor_directions.push_back(vec3(in));  // length mismatch
  field.sources = indices(in, nv, 2);
  field.sinks = indices(in, nv, 2);
  field.smoothing_iterations = in.ConsumeIntegralInRange<int>(-2, 40);

  texsynth::JumpSynthParams params;
  params.scale = fuzz::hostile_double(in, 0.01, 40);
  params.jump_rate = fuzz::hostile_double(in, 0.01, 100);
  params.seed = in.ConsumeIntegral<uint64_t>();
  params.blend = in.ConsumeBool();
  params.allow_oversized = in.ConsumeBool();
  params.border_ramp = fuzz::hostile_double(in, -2, 30);
  params.max_rejection_draws = in.ConsumeIntegralInRange<int>(-2, 20);
  std::vector<float> multiplier;
  if (in.ConsumeIntegralInRange<int>(0, 3) == 0)
    for (int32_t i = 0; i < nv; ++i) multiplier.push_back(fuzz::hostile_float(in, 0.1f, 4));
  params.scale_multiplier = multiplier.empty() ? nullptr : multiplier.data();

  const texsynth::PolyMeshInput input = fuzz_mesh.input();
  texsynth::Mesh mesh;
  try {
    mesh = texsynth::build_mesh(input, normals.empty() ? nullptr : normals.data());
  } catch (const std::invalid_argument&) {
    return 0;
  }
  fuzz::require(mesh.normals.size() == size_t(nv) * 3, "normals sized");
  for (float x : mesh.normals) fuzz::require(std::isfinite(x), "finite normals");
  for (int32_t v = 0; v < nv; ++v)
    for (int32_t i = mesh.neighbour_start[v]; i < mesh.neighbour_start[v + 1]; ++i)
      fuzz::require(mesh.neighbours[i] >= 0 && mesh.neighbours[i] < nv && mesh.neighbours[i] != v, "valid one-ring");

  std::vector<float> up;
  try {
    up = texsynth::compute_orientation_field(mesh, field);
  } catch (const std::invalid_argument&) {
    return 0;
  }
  fuzz::require(up.size() == size_t(nv) * 3, "field sized");
  for (float x : up) fuzz::require(std::isfinite(x), "finite field");

  texsynth::JumpSynthResult result;
  try {
    result = texsynth::synthesize_jumpmap(sample(), mesh, up.data(), params);
  } catch (const std::invalid_argument&) {
    return 0;
  }
  const size_t L = size_t(mesh.num_corners), S = size_t(result.maps.num_blend_sets);
  fuzz::require(result.maps.base_uv.size() == L * 2, "base_uv sized");
  fuzz::require(result.maps.blend_uv.size() == S * L * 2, "blend_uv sized");
  fuzz::require(result.maps.blend_weights.size() == L * S, "blend_weights sized");
  for (float x : result.maps.base_uv) fuzz::require(std::isfinite(x), "finite base_uv");
  for (float x : result.maps.blend_uv) fuzz::require(std::isfinite(x), "finite blend_uv");
  for (float x : result.maps.blend_weights) fuzz::require(x >= 0.0f && x <= 1.0f, "weights in [0, 1]");
  return 0;
}
