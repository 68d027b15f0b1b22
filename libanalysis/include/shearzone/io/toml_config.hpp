// shearzone/io/toml_config.hpp: TOML configuration files (toml11) with strict keys.
//
// A config file sets options by their long flag names, without the dashes:
//     # synth.toml
//     field = "rotation"
//     omega = 0.01          # rad per frame
//     centre = [256, 256]   # px
// Nested tables flatten to dotted keys ("vane.blades"). Every key must be known:
// require_known() raises ConfigError naming the first unknown key, its line and
// the file, so that a typo can never fall back silently to a default (pbrt's
// ReportUnused rule).
#pragma once

#include <cstddef>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace shearzone::io {

class TomlConfig {
 public:
  /// Parses a file. Missing or unreadable file: InputError naming the path.
  /// Syntax error: ConfigError with file, line and toml11's reason.
  static TomlConfig load(const std::filesystem::path& path);
  /// Parses text (`source` names it in messages).
  static TomlConfig parse(const std::string& text, const std::string& source);

  const std::string& source() const { return source_; }
  /// Every leaf key, flattened and sorted.
  std::vector<std::string> keys() const;
  bool has(const std::string& key) const { return entries_.count(key) != 0; }
  /// 1-based line of the key's value in the file (0 if unknown).
  std::size_t line(const std::string& key) const;

  /// The value as text, the way a command-line flag would spell it: strings as
  /// they are, numbers in shortest round-trip form, booleans as true/false. Arrays
  /// give one text per element. Throws ConfigError if the key is absent.
  const std::vector<std::string>& texts(const std::string& key) const;
  bool is_array(const std::string& key) const;

  /// Typed getters; ConfigError names the key, file, line, value and expected type.
  double get_double(const std::string& key) const;
  long long get_int(const std::string& key) const;
  std::string get_string(const std::string& key) const;
  bool get_bool(const std::string& key) const;
  /// A number or an array of numbers, each finite (an empty array gives none).
  std::vector<double> get_doubles(const std::string& key) const;

  /// ConfigError "<file>:<line>: key "<key>": <what>", the form of every key's refusal.
  [[noreturn]] void fail(const std::string& key, const std::string& what) const;

  /// Throws ConfigError for the first key (in sorted order) not in `known`,
  /// suggesting the closest known key.
  void require_known(const std::vector<std::string>& known) const;

 private:
  struct Entry {
    std::vector<std::string> texts;
    std::string type;  // "string", "integer", "float", "boolean", "array", ...
    bool is_array = false;
    std::size_t line = 0;
  };
  const Entry& entry(const std::string& key) const;
  std::string where(const std::string& key) const;

  std::string source_;
  std::map<std::string, Entry> entries_;
};

/// Levenshtein distance (used for "did you mean" suggestions).
std::size_t edit_distance(const std::string& a, const std::string& b);

}  // namespace shearzone::io
