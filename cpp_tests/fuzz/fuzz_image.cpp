// SPDX-License-Identifier: GPL-3.0-or-later
// Image loader wrapper (OpenImageIO behind load_image/read_image_info): any file content under any
// extension must decode to a valid Image or throw std::invalid_argument.
// Input: byte 0 picks the file extension; the rest is the file.
#include "fuzz_common.hpp"
#include "texsynth/image_files/image_files.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const char* kExtensions[] = {".png", ".jpg", ".exr", ".tif", ".bmp", ".tga", ".hdr", ".ppm", ".gif", ".psd"};
  if (size == 0) return 0;
  const std::string& path = fuzz::scratch_path(kExtensions[data[0] % 10]);
  fuzz::write_file(path, data + 1, size - 1);
  try {
    const texsynth::ImageInfo info = texsynth::read_image_info(path);
    fuzz::require(info.width > 0 && info.height > 0 && info.channels > 0, "header sizes positive");
  } catch (const std::invalid_argument&) {
  }
  texsynth::Image image;
  try {
    image = texsynth::load_image(path);
  } catch (const std::invalid_argument&) {
    return 0;
  }
  fuzz::require(image.width > 0 && image.height > 0 && image.channels > 0, "decoded sizes positive");
  fuzz::require(image.pixels.size() == size_t(image.pixel_count()) * size_t(image.channels), "pixel buffer sized");
  for (float v : image.pixels) fuzz::require(std::isfinite(v), "decoded pixels finite");
  if (image.channels <= 4) {
    const std::vector<float> lab = texsynth::to_feature_colors(image);
    fuzz::require(lab.size() == size_t(image.pixel_count()) * size_t(texsynth::feature_channel_count(image)),
                  "feature colours sized");
    for (float v : lab) fuzz::require(std::isfinite(v), "feature colours finite");
  }
  return 0;
}
