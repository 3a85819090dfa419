// SPDX-License-Identifier: GPL-3.0-or-later
// Cache loader: any byte string must load as a fully consistent Preprocessed or throw CacheError,
// and whatever loads must be safe to synthesize from.
// Input: byte 0 = mode; rest = file body. Mode bit 0 set: the harness appends the correct checksum,
// so mutations get past the checksum and reach the semantic validation behind it.
#include <cstring>

#include "fuzz_common.hpp"
#include "texsynth/common/errors.hpp"
#include "texsynth/mesh/mesh.hpp"
#include "texsynth/preprocess/cache.hpp"
#include "texsynth/synth/jumpmap_synth.hpp"

namespace {

void check_loaded(const texsynth::Preprocessed& r) {
  const size_t n = size_t(r.width) * size_t(r.height);
  fuzz::require(r.width > 0 && r.height > 0, "positive size");
  fuzz::require(r.texton_map.size() == n && r.bucket_pixels.size() == n, "per-pixel arrays sized");
  fuzz::require(r.bucket_start.size() == size_t(r.num_textons) + 1, "bucket_start sized");
  fuzz::require(r.jump_map.targets.size() == n * size_t(r.jump_map.k), "jump targets sized");
  for (int32_t t : r.texton_map) fuzz::require(t >= 0 && t < r.num_textons, "texton label in range");
  for (int32_t t : r.jump_map.targets) fuzz::require(t >= -1 && t < int64_t(n), "jump target in range");
}

// A 3x3-vertex quad grid, 1 unit per quad.
void synthesize_on_grid(const texsynth::Preprocessed& pre) {
  static const float positions[] = {0, 0, 0, 1, 0, 0, 2, 0, 0, 0, 1, 0, 1, 1, 0, 2, 1, 0, 0, 2, 0, 1, 2, 0, 2, 2, 0};
  static const int32_t corners[] = {0, 1, 4, 3, 1, 2, 5, 4, 3, 4, 7, 6, 4, 5, 8, 7};
  static const int32_t starts[] = {0, 4, 8, 12}, sizes[] = {4, 4, 4, 4};
  texsynth::PolyMeshInput in{positions, 9, corners, 16, starts, sizes, 4};
  const texsynth::Mesh mesh = texsynth::build_mesh(in);
  std::vector<float> up(27, 0.0f);
  for (int v = 0; v < 9; ++v) up[3 * v + 1] = 1.0f;
  texsynth::JumpSynthParams params;
  params.scale = 2.0;
  params.allow_oversized = true;
  const auto out = texsynth::synthesize_jumpmap(pre, mesh, up.data(), params);
  for (float uv : out.maps.base_uv) fuzz::require(std::isfinite(uv), "finite UVs from a loaded cache");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const std::vector<uint8_t> body =
      fuzz::cache_body(data, size, [](const void* d, size_t n) { return texsynth::cache_checksum(d, n); });
  const std::string& path = fuzz::scratch_path(".tscache");
  fuzz::write_file(path, body.data(), body.size());
  texsynth::Preprocessed loaded;
  try {
    loaded = texsynth::load_preprocessed(path);
  } catch (const texsynth::CacheError&) {
    return 0;
  }
  check_loaded(loaded);
  // cache_state never throws and agrees with the loader.
  fuzz::require(texsynth::cache_state(path, loaded.sample_hash, loaded.params) == texsynth::CacheState::kFresh,
                "a loadable cache is fresh for its own hash and params");
  try {
    synthesize_on_grid(loaded);
  } catch (const std::invalid_argument&) {
    // A consistent but unusable cache (e.g. sample smaller than a face) may be refused, never crash.
  }
  return 0;
}
