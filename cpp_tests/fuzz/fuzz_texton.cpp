// SPDX-License-Identifier: GPL-3.0-or-later
// Texton-string synthesis entry points: synthesize_texton and edge_continuity_error on fuzzed
// meshes (either random topology with hostile indices, or a small jittered grid so that growth,
// search and edge blending really run), fuzzed orientation fields, sample images (right, wrong
// size, NaN pixels) and every TextonSynthParams field. Each call must either throw
// std::invalid_argument or return complete, finite, consistently sized output.
#include "../synthetic_texture.hpp"
#include "fuzz_meshes.hpp"
#include "texsynth/field/orientation_field.hpp"
#include "texsynth/mesh/mesh.hpp"
#include "texsynth/preprocess/preprocess.hpp"
#include "texsynth/synth/texton_synth.hpp"

namespace {

struct Sample {
  texsynth::Image image;
  texsynth::Preprocessed pre;
};

const Sample& sample(bool tileable) {
  auto make = [](bool wrap) {
    Sample s;
    s.image = texsynth_test::brick_texture(40, 32, 5);
    texsynth::PreprocessParams p;
    p.neighbourhood = 5;
    p.num_textons = 8;
    p.feature_dims = 8;
    p.tileable = wrap;
    s.pre = texsynth::preprocess(s.image, p);
    return s;
  };
  static const Sample clamped = make(false), wrapped = make(true);
  return tileable ? wrapped : clamped;
}

void check_result(const texsynth::Mesh& mesh, const texsynth::TextonSynthResult& r) {
  const size_t L = size_t(mesh.num_corners), S = size_t(r.maps.num_blend_sets);
  const size_t E = size_t(r.edges.num_edges());
  fuzz::require(S >= 1 && S <= 4, "1 to 4 blend sets");
  fuzz::require(r.maps.base_uv.size() == L * 2, "base_uv sized");
  fuzz::require(r.maps.blend_uv.size() == S * L * 2, "blend_uv sized");
  fuzz::require(r.maps.blend_weights.size() == L * S, "blend_weights sized");
  for (float x : r.maps.base_uv) fuzz::require(std::isfinite(x), "finite base_uv");
  for (float x : r.maps.blend_uv) fuzz::require(std::isfinite(x), "finite blend_uv");
  for (size_t c = 0; c < L; ++c) {
    float sum = 0.f;
    for (size_t s = 0; s < S; ++s) {
      const float w = r.maps.blend_weights[c * S + s];
      fuzz::require(w >= 0.f && w <= 1.f, "weights in [0, 1]");
      sum += w;
    }
    fuzz::require(sum <= 1.f + 1e-5f, "weights sum to at most 1");
  }
  fuzz::require(r.edge_error.size() == E && r.edge_phi.size() == E && r.edge_blended.size() == E, "edge arrays sized");
  for (float e : r.edge_error) fuzz::require(std::isfinite(e) && e >= 0.f, "finite, non-negative E_t");
  fuzz::require(r.edges.corner_edge.size() == L, "corner_edge sized");
  for (int32_t e : r.edges.corner_edge) fuzz::require(e >= -1 && e < int32_t(E), "corner_edge in range");
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  sample(false);
  sample(true);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  FuzzedDataProvider in(data, size);
  const fuzz::FuzzMesh fuzz_mesh = fuzz::any_mesh(in);
  const Sample& s = sample(in.ConsumeBool());

  // The sample given to synthesize: usually the right one, sometimes the wrong size or poisoned.
  std::vector<float> pixels = s.image.pixels;
  texsynth::SampleImage image{pixels.data(), s.image.width, s.image.height, s.image.channels};
  switch (in.ConsumeIntegralInRange<int>(0, 11)) {
    case 0: image.width -= 1; break;
    case 1: image.channels = in.ConsumeIntegralInRange<int>(-1, 6); break;
    case 2: pixels[in.ConsumeIntegralInRange<size_t>(0, pixels.size() - 1)] = fuzz::hostile_float(in, -1, 2); break;
    case 3: image.pixels = nullptr; break;
    default: break;
  }
  if (image.channels > s.image.channels) image.channels = s.image.channels;  // never read past the buffer

  texsynth::TextonSynthParams params;
  params.scale = fuzz::hostile_double(in, 0.01, 30);
  params.seed = in.ConsumeIntegral<uint64_t>();
  params.blend = in.ConsumeBool();
  params.allow_oversized = in.ConsumeBool();
  params.search.top_m = in.ConsumeIntegralInRange<int>(-1, 70);
  params.search.max_vote_points = in.ConsumeIntegralInRange<int>(-1, 260);
  params.search.max_votes = in.ConsumeIntegralInRange<int>(-2, 5000);
  params.search.tie_tolerance = fuzz::hostile_double(in, 0, 2);
  params.has_camera = in.ConsumeBool();
  for (double& c : params.camera) c = fuzz::hostile_double(in, -10, 10);
  if (in.ConsumeBool()) params.blend_threshold = fuzz::hostile_double(in, -1, 50);
  params.lambda = fuzz::hostile_double(in, 0, 1000);
  std::vector<float> multiplier;
  if (in.ConsumeIntegralInRange<int>(0, 3) == 0)
    for (int32_t i = 0; i < fuzz_mesh.num_vertices; ++i) multiplier.push_back(fuzz::hostile_float(in, 0.1f, 4));
  params.scale_multiplier = multiplier.empty() ? nullptr : multiplier.data();

  texsynth::Mesh mesh;
  try {
    mesh = texsynth::build_mesh(fuzz_mesh.input());
  } catch (const std::invalid_argument&) {
    return 0;
  }
  std::vector<float> up;
  if (in.ConsumeIntegralInRange<int>(0, 3) == 0) {  // a given, possibly hostile, field
    for (int32_t i = 0; i < mesh.num_vertices * 3; ++i) up.push_back(fuzz::hostile_float(in, -1, 1));
  } else {
    texsynth::FieldParams field;
    field.axis = {fuzz::hostile_float(in, -1, 1), fuzz::hostile_float(in, -1, 1), fuzz::hostile_float(in, -1, 1)};
    try {
      up = texsynth::compute_orientation_field(mesh, field);
    } catch (const std::invalid_argument&) {
      return 0;
    }
  }

  texsynth::TextonSynthResult result;
  try {
    result = texsynth::synthesize_texton(s.pre, mesh, up.data(), image, params);
  } catch (const std::invalid_argument&) {
    return 0;
  }
  check_result(mesh, result);

  // E_t for arbitrary UVs (NaN, huge, outside the sample) on the same edges.
  std::vector<float> uv = result.maps.base_uv;
  for (size_t i = 0; i < uv.size() && in.remaining_bytes() > 0; i += 1 + in.ConsumeIntegralInRange<size_t>(0, 7))
    uv[i] = fuzz::hostile_float(in, -3, 3);
  try {
    const std::vector<float> error =
        texsynth::edge_continuity_error(mesh, result.edges, uv.data(), image, s.pre.params.tileable);
    fuzz::require(error.size() == size_t(result.edges.num_edges()), "E_t sized");
    for (float e : error) fuzz::require(std::isfinite(e) && e >= 0.f, "finite, non-negative E_t for any UVs");
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
