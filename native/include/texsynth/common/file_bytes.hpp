// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Whole-file reads and atomic writes for the cache files.
#include <cstdint>
#include <string>
#include <vector>

namespace texsynth {

// Reads the first min(file size, max_bytes) bytes and reports the whole file's size. CacheError
// ("cache '<path>': ...") for a missing, non-regular or unreadable file.
std::vector<uint8_t> read_file_bytes(const std::string& path, uint64_t max_bytes, uint64_t& file_size);

// Writes `bytes` to a temporary file in the same directory, then renames it over `path`: a reader
// sees the old file or the complete new one. std::runtime_error naming `what` and the path on failure.
void write_file_atomically(const std::string& path, const std::vector<uint8_t>& bytes, const std::string& what);

}  // namespace texsynth
