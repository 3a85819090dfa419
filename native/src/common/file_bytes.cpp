// SPDX-License-Identifier: GPL-3.0-or-later
#include "texsynth/common/file_bytes.hpp"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "texsynth/common/errors.hpp"

namespace texsynth {
namespace fs = std::filesystem;

std::vector<uint8_t> read_file_bytes(const std::string& path, uint64_t max_bytes, uint64_t& file_size) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw CacheError("cache '" + path + "': missing or not a regular file");
  file_size = fs::file_size(path, ec);
  if (ec) throw CacheError("cache '" + path + "': cannot read size");
  std::vector<uint8_t> bytes(std::min(file_size, max_bytes));
  std::ifstream in(path, std::ios::binary);
  if (!in || !in.read(reinterpret_cast<char*>(bytes.data()), std::streamsize(bytes.size())))
    throw CacheError("cache '" + path + "': cannot read file");
  return bytes;
}

void write_file_atomically(const std::string& path, const std::vector<uint8_t>& bytes, const std::string& what) {
  static std::atomic<uint64_t> counter{0};
  const fs::path target(path);
  const fs::path temp = target.parent_path() / ("." + target.filename().string() + ".tmp." +
                                                std::to_string(::getpid()) + "." + std::to_string(counter++));
  {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    if (!out) throw std::runtime_error("cannot write " + what + " '" + temp.string() + "'");
    out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    out.flush();
    if (!out) {
      std::error_code ec;
      fs::remove(temp, ec);
      throw std::runtime_error("cannot write " + what + " '" + temp.string() + "' (disk full?)");
    }
  }
  std::error_code ec;
  fs::rename(temp, target, ec);
  if (ec) {
    fs::remove(temp, ec);
    throw std::runtime_error("cannot move " + what + " into place at '" + path + "'");
  }
}

}  // namespace texsynth
