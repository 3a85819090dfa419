// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// 32-bit float OpenEXR files TexSynth writes for itself (the cache's side files), through tinyexr compiled
// into the core, so the module Blender loads needs no image library (docs/dev/blender_org_packages.md).
// Scanline, ZIP-compressed, one part. Channels are given interleaved in the caller's order and stored
// sorted by name, as OpenEXR requires; reading maps them back by name.
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace texsynth {

struct FloatExrTags {
  std::map<std::string, int> ints;             // EXR attribute type "int"
  std::map<std::string, std::string> strings;  // EXR attribute type "string"; empty strings are not written
};

// Writes `data` (height*width*channel_names.size() floats, row 0 = top) to `path` directly (callers that
// need an atomic replace write a temporary and rename it). Throws std::runtime_error naming the path.
void write_float_exr(const std::string& path, const std::vector<float>& data, int width, int height,
                     const std::vector<std::string>& channel_names, const FloatExrTags& tags);

struct FloatExr {
  std::vector<float> data;  // interleaved in the order of the requested channel names
  FloatExrTags tags;        // every int and string attribute the file carries
};

// The file's pixels if it is a single-part scanline float EXR of exactly this size and these channel
// names, every value finite; nullopt for anything else (missing, truncated, another layout, corrupt).
// The size is checked against the header before any pixel is decoded.
std::optional<FloatExr> read_float_exr(const std::string& path, int width, int height,
                                       const std::vector<std::string>& channel_names);

}  // namespace texsynth
