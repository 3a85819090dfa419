// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/preprocess/gaussianize.hpp"

#include "texsynth/common/float_exr.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <stdexcept>
#include <unistd.h>

namespace texsynth {
namespace fs = std::filesystem;

namespace {

constexpr int kFileVersion = 1;
constexpr double kGaussianMean = 0.5;
constexpr double kGaussianStd = 1.0 / 6.0;

// Lower half of the inverse normal CDF, p in (0, 0.5]. Acklam's rational approximation (|rel. error|
// < 1.2e-9), then one Halley step on Φ(x) - p, which brings it to double precision.
double quantile_lower(double p) {
  static constexpr double a[6] = {-3.969683028665376e+01, 2.209460984245205e+02, -2.759285104469687e+02,
                                  1.383577518672690e+02,  -3.066479806614716e+01, 2.506628277459239e+00};
  static constexpr double b[5] = {-5.447609879822406e+01, 1.615858368580409e+02, -1.556989798598866e+02,
                                  6.680131188771972e+01,  -1.328068155288572e+01};
  static constexpr double c[6] = {-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e+00,
                                  -2.549732539343734e+00, 4.374664141464968e+00,  2.938163982698783e+00};
  static constexpr double d[4] = {7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e+00,
                                  3.754408661907416e+00};
  double x;
  if (p < 0.02425) {
    const double q = std::sqrt(-2.0 * std::log(p));
    x = (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
        ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1.0);
  } else {
    const double q = p - 0.5, r = q * q;
    x = (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q /
        (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1.0);
  }
  const double e = normal_cdf(x) - p;
  const double u = e * std::sqrt(2.0 * M_PI) * std::exp(0.5 * x * x);
  return x - u / (1.0 + 0.5 * x * u);
}

// Order-preserving unsigned key of a float; -0 and +0 are the same value, so they get the same key.
uint32_t order_key(float v) {
  if (v == 0.0f) v = 0.0f;
  uint32_t bits;
  std::memcpy(&bits, &v, 4);
  return (bits & 0x80000000u) ? ~bits : (bits | 0x80000000u);
}

// Sorts pixel indices by key with a stable LSD radix sort (3 passes of 11 bits): equal keys keep
// increasing pixel order, so the result is the (value, pixel index) order, deterministically.
template <typename Keys, typename Order>
void radix_sort(size_t n, Keys& keys, Order& order, Keys& key_tmp, Order& order_tmp) {
  std::vector<size_t> count(2048);
  for (int shift = 0; shift < 32; shift += 11) {
    std::fill(count.begin(), count.end(), 0);
    for (size_t i = 0; i < n; ++i) ++count[(keys[i] >> shift) & 2047u];
    if (std::find(count.begin(), count.end(), n) != count.end()) continue;  // one digit for all: nothing moves
    size_t sum = 0;
    for (size_t& c : count) {
      const size_t here = c;
      c = sum;
      sum += here;
    }
    for (size_t i = 0; i < n; ++i) {
      const size_t at = count[(keys[i] >> shift) & 2047u]++;
      key_tmp[at] = keys[i];
      order_tmp[at] = order[i];
    }
    keys.swap(key_tmp);
    order.swap(order_tmp);
  }
}

float identity_entry(int i, int lut_size) { return float((i + 0.5) / lut_size); }

void fill_identity(std::vector<float>& lut, int lut_size, int channels, int channel) {
  for (int i = 0; i < lut_size; ++i) lut[size_t(i) * channels + channel] = identity_entry(i, lut_size);
}

void check_parameters(int lut_size, int min_distinct_values) {
  if (lut_size < kMinHistogramLutSize || lut_size > kMaxHistogramLutSize)
    throw std::invalid_argument("lut_size must be in [" + std::to_string(kMinHistogramLutSize) + ", " +
                                std::to_string(kMaxHistogramLutSize) + "], got " + std::to_string(lut_size));
  if (min_distinct_values < kMinDistinctValuesLimit || min_distinct_values > kMaxDistinctValuesLimit)
    throw std::invalid_argument("min_distinct_values must be in [" + std::to_string(kMinDistinctValuesLimit) + ", " +
                                std::to_string(kMaxDistinctValuesLimit) + "], got " +
                                std::to_string(min_distinct_values));
}

// Buffers for one channel at a time, reused across channels and left uninitialised: touching fresh
// multi-megabyte allocations (a page fault per 4 KiB, then zeroing) dominated the run time.
template <typename T>
struct Buffer {
  explicit Buffer(size_t n) : data(new T[n]) {}
  T& operator[](size_t i) { return data[i]; }
  const T& operator[](size_t i) const { return data[i]; }
  void swap(Buffer& other) { data.swap(other.data); }
  std::unique_ptr<T[]> data;
};

struct Workspace {
  explicit Workspace(size_t n) : keys(n), key_tmp(n), order(n), order_tmp(n), gaussian(n) {}
  Buffer<uint32_t> keys, key_tmp;
  Buffer<int32_t> order, order_tmp;
  Buffer<float> gaussian;  // planar result of the channel
};

struct ChannelResult {
  size_t distinct = 0;
  std::vector<float> lut;  // only when distinct is enough (then w.gaussian holds the channel)
};

// Sorts one channel, counts its distinct values and, when there are enough, Gaussianizes it into
// w.gaussian and builds its inverse LUT column.
ChannelResult transform_channel(const Image& image, int c, int lut_size, int min_distinct_values, Workspace& w) {
  const int channels = image.channels;
  const size_t n = size_t(image.pixel_count());
  Buffer<uint32_t>& keys = w.keys;
  Buffer<int32_t>& order = w.order;
  for (size_t p = 0; p < n; ++p) {
    keys[p] = order_key(image.pixels[p * channels + c]);
    order[p] = int32_t(p);
  }
  radix_sort(n, keys, order, w.key_tmp, w.order_tmp);

  // Tie groups [i, j): every member gets twice the group's mean rank, i + j - 1 (an integer).
  Buffer<uint32_t>& twice_rank = w.key_tmp;
  ChannelResult result;
  for (size_t i = 0; i < n;) {
    size_t j = i + 1;
    while (j < n && keys[j] == keys[i]) ++j;
    for (size_t s = i; s < j; ++s) twice_rank[s] = uint32_t(i + j - 1);
    ++result.distinct;
    i = j;
  }
  if (result.distinct < size_t(min_distinct_values)) return result;

  // u = (rank + 0.5) / N, g = 0.5 + Φ⁻¹(u) / 6. Each value depends only on its rank: deterministic
  // for any split of the work.
  float* gaussian = w.gaussian.data.get();
  const double two_n = 2.0 * double(n);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 16384), [&](const tbb::blocked_range<size_t>& r) {
    uint32_t last = UINT32_MAX;
    float g = 0.0f;
    for (size_t s = r.begin(); s < r.end(); ++s) {
      if (twice_rank[s] != last) {
        last = twice_rank[s];
        const double u = (double(last) + 1.0) / two_n;
        g = float(std::clamp(kGaussianMean + kGaussianStd * normal_quantile(u), 0.0, 1.0));
      }
      gaussian[order[s]] = g;
    }
  });

  // Entry i: the sample's quantile at u_i = Φ((g_i - 0.5) * 6), interpolated between sorted values at
  // continuous position u_i * N - 0.5. The running maximum guards monotonicity against rounding.
  auto sorted_value = [&](size_t s) { return double(image.pixels[size_t(order[s]) * channels + c]); };
  result.lut.resize(size_t(lut_size));
  float previous = -HUGE_VALF;
  for (int i = 0; i < lut_size; ++i) {
    const double g = (i + 0.5) / lut_size;
    const double u = normal_cdf((g - kGaussianMean) / kGaussianStd);
    const double position = std::clamp(u * double(n) - 0.5, 0.0, double(n - 1));
    const size_t lo = std::min(size_t(position), n - 1), hi = std::min(lo + 1, n - 1);
    const double a = sorted_value(lo), b = sorted_value(hi);
    const double value = std::clamp(a + (position - double(lo)) * (b - a), a, b);
    previous = std::max(previous, float(value));
    result.lut[size_t(i)] = previous;
  }
  return result;
}

bool has_alpha(int channels) { return channels == 2 || channels == 4; }

}  // namespace

std::vector<std::string> histogram_channel_names(int channels) {
  switch (channels) {
    case 1: return {"Y"};
    case 2: return {"Y", "A"};
    case 3: return {"R", "G", "B"};
    default: return {"R", "G", "B", "A"};
  }
}

namespace {

// What both cache files carry; a pair whose tags differ was not written together.
struct FileTags {
  int version = 0;
  int ok = -1;
  std::string reason;
  int colour_channels = 0;
  int min_distinct_values = 0;
  bool operator==(const FileTags& o) const {
    return version == o.version && ok == o.ok && reason == o.reason && colour_channels == o.colour_channels &&
           min_distinct_values == o.min_distinct_values;
  }
};

FloatExrTags exr_tags(const FileTags& tags) {
  FloatExrTags exr;
  exr.ints = {{"texsynth:histogram_version", tags.version},
              {"texsynth:ok", tags.ok},
              {"texsynth:colour_channels", tags.colour_channels},
              {"texsynth:min_distinct_values", tags.min_distinct_values}};
  exr.strings = {{"texsynth:fallback_reason", tags.reason}};
  return exr;
}

int int_tag(const FloatExrTags& tags, const std::string& name, int missing) {
  const auto found = tags.ints.find(name);
  return found == tags.ints.end() ? missing : found->second;
}

void write_exr(const std::string& path, const std::vector<float>& data, int width, int height, int channels,
               const FileTags& tags) {
  static std::atomic<uint64_t> counter{0};
  const fs::path target(path);
  // Ends in .exr so a leftover temporary is recognisable.
  const fs::path temp = target.parent_path() / ("." + target.filename().string() + ".tmp." +
                                                std::to_string(::getpid()) + "." + std::to_string(counter++) + ".exr");
  try {
    write_float_exr(temp.string(), data, width, height, histogram_channel_names(channels), exr_tags(tags));
  } catch (const std::exception& error) {
    std::error_code ec;
    fs::remove(temp, ec);
    throw std::runtime_error("cannot write '" + path + "': " + error.what() + " (disk full?)");
  }
  std::error_code ec;
  fs::rename(temp, target, ec);
  if (ec) {
    fs::remove(temp, ec);
    throw std::runtime_error("cannot write '" + path + "': cannot move the temporary file into place (" +
                             ec.message() + ")");
  }
}

// The pixels of a float EXR of exactly this size and channel layout, or nullopt for anything else.
std::optional<std::vector<float>> read_exr(const std::string& path, int width, int height, int channels,
                                           FileTags& tags) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return std::nullopt;
  std::optional<FloatExr> file = read_float_exr(path, width, height, histogram_channel_names(channels));
  if (!file) return std::nullopt;
  tags.version = int_tag(file->tags, "texsynth:histogram_version", 0);
  tags.ok = int_tag(file->tags, "texsynth:ok", -1);
  const auto reason = file->tags.strings.find("texsynth:fallback_reason");
  tags.reason = reason == file->tags.strings.end() ? std::string() : reason->second;
  tags.colour_channels = int_tag(file->tags, "texsynth:colour_channels", 0);
  tags.min_distinct_values = int_tag(file->tags, "texsynth:min_distinct_values", 0);
  return std::move(file->data);
}

}  // namespace

double normal_cdf(double x) { return 0.5 * std::erfc(-x / std::sqrt(2.0)); }

double normal_quantile(double p) {
  if (!(p > 0.0)) return p == 0.0 ? -HUGE_VAL : std::nan("");
  if (!(p < 1.0)) return p == 1.0 ? HUGE_VAL : std::nan("");
  // 1 - p is exact for p >= 0.5, and the lower tail keeps full relative precision.
  return p <= 0.5 ? quantile_lower(p) : -quantile_lower(1.0 - p);
}

int histogram_colour_channels(int channels) { return channels == 2 ? 1 : std::min(channels, 3); }

HistogramTransform gaussianize(const Image& image, int lut_size, int min_distinct_values) {
  check_parameters(lut_size, min_distinct_values);
  validate_image(image);
  const int channels = image.channels;
  const size_t n = size_t(image.pixel_count());
  HistogramTransform t;
  t.width = image.width;
  t.height = image.height;
  t.channels = channels;
  t.colour_channels = histogram_colour_channels(channels);
  t.lut_size = lut_size;
  t.min_distinct_values = min_distinct_values;
  t.gaussian = image.pixels;  // alpha (and, for a fallback, everything) stays as it is
  t.inverse_lut.assign(size_t(lut_size) * channels, 0.0f);
  for (int c = 0; c < channels; ++c) fill_identity(t.inverse_lut, lut_size, channels, c);

  // One channel at a time (memory: 20 bytes per pixel besides the result); the work inside is parallel.
  const int colour = t.colour_channels;
  Workspace workspace(n);
  std::vector<ChannelResult> results(static_cast<size_t>(colour));
  for (int c = 0; c < colour; ++c) {
    results[size_t(c)] = transform_channel(image, c, lut_size, min_distinct_values, workspace);
    if (results[size_t(c)].lut.empty()) continue;
    const float* planar = workspace.gaussian.data.get();
    for (size_t p = 0; p < n; ++p) t.gaussian[p * channels + c] = planar[p];
  }

  std::string reasons;
  for (int c = 0; c < colour; ++c) {
    const size_t distinct = results[size_t(c)].distinct;
    if (distinct >= size_t(min_distinct_values)) continue;
    if (!reasons.empty()) reasons += "; ";
    reasons += "channel " + std::to_string(c) +
               (distinct == 1 ? " is constant"
                              : " has only " + std::to_string(distinct) + " distinct values (at least " +
                                    std::to_string(min_distinct_values) + " are needed)");
  }
  t.ok = reasons.empty();
  t.fallback_reason = reasons;
  if (!t.ok) {  // identity LUT, original values
    t.gaussian = image.pixels;
    return t;
  }
  for (int c = 0; c < colour; ++c)
    for (int i = 0; i < lut_size; ++i) t.inverse_lut[size_t(i) * channels + c] = results[size_t(c)].lut[size_t(i)];
  return t;
}

float inverse_lut_lookup(const HistogramTransform& t, int channel, float g) {
  if (channel < 0 || channel >= t.channels || t.lut_size < 1 ||
      t.inverse_lut.size() != size_t(t.lut_size) * size_t(t.channels))
    throw std::invalid_argument("inverse_lut_lookup: no such channel, or inconsistent transform");
  const double position = std::clamp(double(g) * t.lut_size - 0.5, 0.0, double(t.lut_size - 1));
  const int lo = std::min(int(position), t.lut_size - 1), hi = std::min(lo + 1, t.lut_size - 1);
  const double a = t.inverse_lut[size_t(lo) * t.channels + channel];
  const double b = t.inverse_lut[size_t(hi) * t.channels + channel];
  return float(a + (position - lo) * (b - a));
}

std::string histogram_file_stem(const std::string& cache_dir, uint64_t sample_hash, int lut_size) {
  char name[64];
  std::snprintf(name, sizeof(name), "%016llx-hist%d", static_cast<unsigned long long>(sample_hash), lut_size);
  return (fs::path(cache_dir) / name).string();
}

std::string histogram_gaussian_path(const std::string& stem) { return stem + ".gauss.exr"; }
std::string histogram_lut_path(const std::string& stem) { return stem + ".lut.exr"; }

void save_histogram_transform(const HistogramTransform& t, const std::string& stem) {
  const bool consistent =
      t.width > 0 && t.height > 0 && t.width <= kMaxImageSide && t.height <= kMaxImageSide && t.channels >= 1 &&
      t.channels <= 4 && t.colour_channels == histogram_colour_channels(t.channels) &&
      t.lut_size >= kMinHistogramLutSize && t.lut_size <= kMaxHistogramLutSize &&
      t.gaussian.size() == size_t(t.width) * size_t(t.height) * size_t(t.channels) &&
      t.inverse_lut.size() == size_t(t.lut_size) * size_t(t.channels) && t.ok == t.fallback_reason.empty();
  if (!consistent) throw std::invalid_argument("save_histogram_transform: inconsistent HistogramTransform");
  const FileTags tags{kFileVersion, t.ok ? 1 : 0, t.fallback_reason, t.colour_channels, t.min_distinct_values};
  write_exr(histogram_gaussian_path(stem), t.gaussian, t.width, t.height, t.channels, tags);
  write_exr(histogram_lut_path(stem), t.inverse_lut, t.lut_size, 1, t.channels, tags);
}

std::optional<HistogramTransform> load_histogram_transform(const std::string& stem, int width, int height,
                                                           int channels, int lut_size) {
  try {
    if (width <= 0 || height <= 0 || width > kMaxImageSide || height > kMaxImageSide ||
        int64_t(width) * height > kMaxImagePixels || channels < 1 || channels > 4 ||
        lut_size < kMinHistogramLutSize || lut_size > kMaxHistogramLutSize)
      return std::nullopt;
    // The small file first: a missing or stale pair is usually caught before the big read.
    FileTags lut_tags, gauss_tags;
    auto lut = read_exr(histogram_lut_path(stem), lut_size, 1, channels, lut_tags);
    if (!lut) return std::nullopt;
    const int colour = histogram_colour_channels(channels);
    if (lut_tags.version != kFileVersion || (lut_tags.ok != 0 && lut_tags.ok != 1) ||
        (lut_tags.ok == 1) != lut_tags.reason.empty() || lut_tags.colour_channels != colour ||
        lut_tags.min_distinct_values < kMinDistinctValuesLimit ||
        lut_tags.min_distinct_values > kMaxDistinctValuesLimit)
      return std::nullopt;
    for (int c = 0; c < channels; ++c) {
      const bool identity = c >= colour || lut_tags.ok == 0;
      for (int i = 0; i < lut_size; ++i) {
        const float v = (*lut)[size_t(i) * channels + c];
        if (identity && v != identity_entry(i, lut_size)) return std::nullopt;
        if (i > 0 && v < (*lut)[size_t(i - 1) * channels + c]) return std::nullopt;
      }
    }
    auto gaussian = read_exr(histogram_gaussian_path(stem), width, height, channels, gauss_tags);
    if (!gaussian || !(gauss_tags == lut_tags)) return std::nullopt;
    if (lut_tags.ok == 1) {
      const size_t n = size_t(width) * size_t(height);
      for (size_t p = 0; p < n; ++p)
        for (int c = 0; c < colour; ++c) {
          const float g = (*gaussian)[p * channels + c];
          if (!(g >= 0.0f && g <= 1.0f)) return std::nullopt;
        }
    }
    HistogramTransform t;
    t.width = width;
    t.height = height;
    t.channels = channels;
    t.colour_channels = colour;
    t.gaussian = std::move(*gaussian);
    t.lut_size = lut_size;
    t.inverse_lut = std::move(*lut);
    t.ok = lut_tags.ok == 1;
    t.fallback_reason = lut_tags.reason;
    t.min_distinct_values = lut_tags.min_distinct_values;
    return t;
  } catch (...) {  // out of memory while reading: treat as stale
    return std::nullopt;
  }
}

HistogramTransform histogram_transform_cached(const Image& image, uint64_t sample_hash, const std::string& cache_dir,
                                              int lut_size, int min_distinct_values) {
  check_parameters(lut_size, min_distinct_values);
  validate_image(image);
  if (cache_dir.empty()) throw std::invalid_argument("cache_dir is empty");
  const std::string stem = histogram_file_stem(cache_dir, sample_hash, lut_size);
  if (auto cached = load_histogram_transform(stem, image.width, image.height, image.channels, lut_size)) {
    // Made with the same threshold, and what was copied from the sample still matches it.
    bool fits = cached->min_distinct_values == min_distinct_values;
    const size_t n = size_t(image.pixel_count());
    const int channels = image.channels;
    for (size_t p = 0; fits && p < n; ++p)
      for (int c = cached->ok ? cached->colour_channels : 0; c < channels; ++c)
        fits &= cached->gaussian[p * channels + c] == image.pixels[p * channels + c];
    if (fits) return std::move(*cached);
  }
  HistogramTransform t = gaussianize(image, lut_size, min_distinct_values);
  std::error_code ec;
  fs::create_directories(cache_dir, ec);
  if (ec) throw std::runtime_error("cannot create cache directory '" + cache_dir + "': " + ec.message());
  save_histogram_transform(t, stem);
  return t;
}

}  // namespace texsynth
