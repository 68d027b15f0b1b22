#include "shearzone/io/file.hpp"

#include <algorithm>
#include <cctype>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"

namespace shearzone::io {

std::string read_file_bytes(const std::filesystem::path& path, const std::string& kind) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec))
    throw InputError(fmt::format("{}: no such {}", path.string(), kind));
  if (std::filesystem::is_directory(path, ec))
    throw InputError(fmt::format("{}: is a folder; expected a {}", path.string(), kind));
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(fmt::format("{}: cannot open for reading", path.string()));
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw InputError(fmt::format("{}: read error", path.string()));
  return ss.str();
}

bool has_extension(const std::filesystem::path& path, std::string_view ext) {
  const std::string e = path.extension().string();
  const auto same = [](unsigned char a, unsigned char b) { return std::tolower(a) == std::tolower(b); };
  return std::equal(e.begin(), e.end(), ext.begin(), ext.end(), same);
}

}  // namespace shearzone::io
