// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Support for histogram-preserving blending (Heitz & Neyret 2018, "High-Performance By-Example Noise
// using a Histogram-Preserving Blending Operator"): each colour channel of the sample is mapped through
// its own CDF onto a Gaussian with mean 0.5 and standard deviation 1/6 (clamped to [0, 1]), so that
// variance-preserving blends of Gaussianized patches keep that Gaussian; a per-channel inverse look-up
// table then maps blended values back to the sample's own histogram.
//
// Values are taken as the Image holds them (the file's encoded values, not linearised): the inverse
// LUT must reproduce exactly the numbers the shader would otherwise have sampled.
//
// Ties: equal values share the mean rank of their group, so equal inputs map to equal outputs.
// Colour channels: 1 -> 1, 2 (grey + alpha) -> 1, 3 -> 3, 4 (RGBA) -> 3. Alpha is copied unchanged
// and its LUT column is the identity.
//
// Fallback: a channel with too few distinct values (a flat colour, a two-tone mask) has no useful
// Gaussian; then the whole transform is the identity (ok = false, fallback_reason says why), so a
// caller can blend the sample linearly without a special case.
//
// Cache files (histogram_file_stem): "<stem>.gauss.exr" (W×H×C) and "<stem>.lut.exr" (lut_size×1×C),
// 32-bit float OpenEXR written with tinyexr (common/float_exr.hpp); zip, as an 8-bit sample's Gaussian
// has <= 256 values per channel and shrinks >10×; channels named Y / Y,A / R,G,B / R,G,B,A. Both carry
// the same header attributes, and a pair that disagrees is stale (the two renames are not one atomic step):
//   texsynth:histogram_version (int, 1), texsynth:ok (int 0/1), texsynth:fallback_reason (string;
//   not written when empty, i.e. when ok), texsynth:colour_channels (int),
//   texsynth:min_distinct_values (int).
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "texsynth/image/image.hpp"

namespace texsynth {

constexpr int kMinHistogramLutSize = 16;
constexpr int kMaxHistogramLutSize = 65536;
constexpr int kMinDistinctValuesLimit = 2;
constexpr int kMaxDistinctValuesLimit = 65536;

struct HistogramTransform {
  int32_t width = 0, height = 0, channels = 0;
  int32_t colour_channels = 0;
  std::vector<float> gaussian;  // H*W*C, row 0 = top, same layout as Image
  int32_t lut_size = 0;
  std::vector<float> inverse_lut;  // lut_size*C (entry-major); entry i is for Gaussian value (i+0.5)/lut_size
  bool ok = false;
  std::string fallback_reason;  // empty when ok
  // The distinct-value threshold this was computed with: it decides ok and the reason's wording, so a
  // cached transform made with another threshold is recomputed.
  int32_t min_distinct_values = 0;
};

// Standard normal CDF Φ and its inverse (p in (0, 1); 0 -> -inf, 1 -> +inf). The inverse is Acklam's
// rational approximation refined by one Halley step: |error| ~ 1e-15 relative.
double normal_cdf(double x);
double normal_quantile(double p);

// Channels that get Gaussianized for an image with `channels` channels (see above).
int histogram_colour_channels(int channels);

// The EXR channel names the cache files use for an image with `channels` channels: Y, YA, RGB or RGBA.
std::vector<std::string> histogram_channel_names(int channels);

// Throws std::invalid_argument for lut_size outside [16, 65536], min_distinct_values outside [2, 65536],
// or an invalid image (size, NaN/Inf: validate_image). Memory: O(pixels) per channel, one channel at a time.
HistogramTransform gaussianize(const Image& image, int lut_size = 1024, int min_distinct_values = 16);

// The inverse LUT of `channel` at Gaussian value g, linearly interpolated between entry centres and
// clamped at the ends (what a linearly filtered lut_size×1 texture returns).
float inverse_lut_lookup(const HistogramTransform& transform, int channel, float g);

// "<cache_dir>/<sample_hash:016x>-hist<lut_size>"; the files are stem + ".gauss.exr" and stem + ".lut.exr".
std::string histogram_file_stem(const std::string& cache_dir, uint64_t sample_hash, int lut_size);
std::string histogram_gaussian_path(const std::string& stem);
std::string histogram_lut_path(const std::string& stem);

// Writes both files, each atomically (temporary file in the same directory, then rename). Throws
// std::invalid_argument for an inconsistent transform, std::runtime_error when writing fails.
void save_histogram_transform(const HistogramTransform& transform, const std::string& stem);

// nullopt (never throws) when either file is missing, unreadable, of another size / channel layout,
// holds non-finite or out-of-range values, a non-monotone LUT, or disagrees with the other file.
std::optional<HistogramTransform> load_histogram_transform(const std::string& stem, int width, int height,
                                                           int channels, int lut_size);

// Loads the cached transform of `image` when it is valid, was made with the same min_distinct_values and
// matches the image's alpha (and, for a fallback, its pixels); otherwise computes and (re)writes it,
// creating cache_dir. sample_hash is image_hash(image). Parameters are checked before anything is written.
HistogramTransform histogram_transform_cached(const Image& image, uint64_t sample_hash, const std::string& cache_dir,
                                              int lut_size = 1024, int min_distinct_values = 16);

}  // namespace texsynth
