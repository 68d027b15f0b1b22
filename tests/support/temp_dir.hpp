// tests/support/temp_dir.hpp: a fresh folder under the build tree's tests/tmp,
// removed when the object goes out of scope. Tests never write to the source tree.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace shearzone::testing {

class TempDir {
 public:
  /// Creates SHEARZONE_TEST_TMP_DIR/<label>-<pid>-<n>.
  explicit TempDir(const std::string& label = "t");
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

/// Writes `text` to `path` (binary).
void write_file(const std::filesystem::path& path, const std::string& text);
/// Reads a whole file (binary).
std::string read_file(const std::filesystem::path& path);
/// Names of the entries of a folder, sorted.
std::vector<std::string> list_dir(const std::filesystem::path& dir);

}  // namespace shearzone::testing
