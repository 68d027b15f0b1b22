// shearzone/io/file.hpp: reading whole files with errors that name them; file-name
// extension checks.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

namespace shearzone::io {

/// The bytes of a file. InputError `<path>: no such <kind>` if it is missing,
/// `<path>: is a folder; expected a <kind>` or `<path>: cannot open for reading`.
std::string read_file_bytes(const std::filesystem::path& path, const std::string& kind = "file");

/// True when the extension of `path` (std::filesystem::path::extension(): from the
/// last dot of the file name, the dot included) is `ext`, ASCII letters compared
/// case-insensitively: has_extension("a/B.CSV", ".csv") is true.
bool has_extension(const std::filesystem::path& path, std::string_view ext);

}  // namespace shearzone::io
