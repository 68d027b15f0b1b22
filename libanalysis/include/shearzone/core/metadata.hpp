// shearzone/core/metadata.hpp: the key/value header every output file carries.
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace shearzone::core {

/// Ordered key/value pairs. Written as `# key: value` lines in CSV files and as
/// string attributes in HDF5 files. Keys are snake_case; values are one line.
using Metadata = std::vector<std::pair<std::string, std::string>>;

/// tool, version, the command line (if given) and the conventions. Stages append
/// their resolved options after these.
Metadata standard_metadata(const std::string& command_line = "");

/// Reconstructs a shell-quoted command line from argv (for output headers).
std::string command_line_from_argv(int argc, const char* const* argv);

/// Returns the value of `key`, or `fallback` when absent.
std::string metadata_value(const Metadata& m, const std::string& key,
                           const std::string& fallback = "");

}  // namespace shearzone::core
