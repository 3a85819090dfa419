// SPDX-License-Identifier: GPL-3.0-or-later
// The cache's EXR side files (common/float_exr, tinyexr): any byte string read as a float EXR of the layout
// the caller expects must give exactly that many finite values or nullopt, never a crash, a hang or a
// read outside the file; what reads must write back and read again unchanged.
// Input: byte 0 = channel count - 1 (mod 4: Y, YA, RGB, RGBA, from histogram_channel_names), bytes 1 and 2 =
// width - 1 and height - 1 (mod 64); the rest = the file.
#include "fuzz_common.hpp"
#include "texsynth/common/float_exr.hpp"
#include "texsynth/preprocess/gaussianize.hpp"

namespace {

// Tags as write_float_exr stores them (it leaves empty strings out).
texsynth::FloatExrTags written_form(texsynth::FloatExrTags tags) {
  for (auto it = tags.strings.begin(); it != tags.strings.end();) it = it->second.empty() ? tags.strings.erase(it) : ++it;
  return tags;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 3) return 0;
  const int channels = data[0] % 4 + 1, width = data[1] % 64 + 1, height = data[2] % 64 + 1;
  const std::vector<std::string> names = texsynth::histogram_channel_names(channels);
  const std::string& path = fuzz::scratch_path(".exr");
  fuzz::write_file(path, data + 3, size - 3);
  std::optional<texsynth::FloatExr> file = texsynth::read_float_exr(path, width, height, names);
  if (!file) return 0;
  fuzz::require(file->data.size() == size_t(width) * size_t(height) * names.size(), "as many values as asked for");
  for (float value : file->data) fuzz::require(std::isfinite(value), "finite values only");
  const texsynth::FloatExrTags tags = written_form(file->tags);
  const std::string copy = path + ".copy.exr";
  texsynth::write_float_exr(copy, file->data, width, height, names, tags);
  std::optional<texsynth::FloatExr> again = texsynth::read_float_exr(copy, width, height, names);
  std::remove(copy.c_str());
  fuzz::require(again.has_value(), "what was read writes back readable");
  fuzz::require(again->data == file->data, "the values survive a write and a read");
  fuzz::require(again->tags.ints == tags.ints && again->tags.strings == tags.strings, "the tags survive");
  return 0;
}
