#include "shearzone/core/metadata.hpp"

#include "shearzone/core/conventions.hpp"
#include "shearzone/core/version.hpp"

namespace shearzone::core {

Metadata standard_metadata(const std::string& command_line) {
  Metadata m{{"tool", kToolName}, {"version", kVersion}};
  if (!command_line.empty()) m.emplace_back("command_line", command_line);
  for (auto& kv : convention_metadata()) m.push_back(std::move(kv));
  return m;
}

std::string command_line_from_argv(int argc, const char* const* argv) {
  std::string out;
  for (int i = 0; i < argc; ++i) {
    std::string a = argv[i] ? argv[i] : "";
    const bool plain = !a.empty() && a.find_first_not_of(
                                         "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                         "0123456789-_./=,:+@%") == std::string::npos;
    if (i) out += ' ';
    if (plain) {
      out += a;
    } else {
      out += '\'';
      for (char c : a) {
        if (c == '\'') out += "'\\''";
        else if (c == '\n') out += ' ';
        else out += c;
      }
      out += '\'';
    }
  }
  return out;
}

std::string metadata_value(const Metadata& m, const std::string& key, const std::string& fallback) {
  for (const auto& [k, v] : m)
    if (k == key) return v;
  return fallback;
}

}  // namespace shearzone::core
