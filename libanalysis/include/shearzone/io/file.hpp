// shearzone/io/file.hpp: reading whole files with errors that name them.
#pragma once

#include <filesystem>
#include <string>

namespace shearzone::io {

/// The bytes of a file. InputError `<path>: no such <kind>` if it is missing,
/// `<path>: is a folder; expected a <kind>` or `<path>: cannot open for reading`.
std::string read_file_bytes(const std::filesystem::path& path, const std::string& kind = "file");

}  // namespace shearzone::io
