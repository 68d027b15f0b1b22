#include "shearzone/io/toml_config.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <toml.hpp>

#include "shearzone/core/error.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/io/file.hpp"

namespace shearzone::io {
namespace {

std::string first_line(const std::string& s) {
  std::string l = s.substr(0, s.find('\n'));
  const std::string tag = "[error] ";
  if (l.rfind(tag, 0) == 0) l = l.substr(tag.size());
  return l;
}

std::string type_name(const toml::value& v) {
  switch (v.type()) {
    case toml::value_t::string: return "string";
    case toml::value_t::integer: return "integer";
    case toml::value_t::floating: return "float";
    case toml::value_t::boolean: return "boolean";
    case toml::value_t::array: return "array";
    case toml::value_t::table: return "table";
    default: return "date/time";
  }
}

std::string scalar_text(const toml::value& v, const std::string& source, const std::string& key) {
  switch (v.type()) {
    case toml::value_t::string: return v.as_string().str;
    case toml::value_t::integer: return std::to_string(v.as_integer());
    case toml::value_t::floating: return format_number(v.as_floating());
    case toml::value_t::boolean: return v.as_boolean() ? "true" : "false";
    default:
      throw ConfigError(fmt::format("{}:{}: key \"{}\": a {} is not allowed here; expected a "
                                    "number, string, boolean or array of them",
                                    source, v.location().line(), key, type_name(v)));
  }
}

/// The TOML parser recurses once per nested array or inline table: 10 000 levels
/// overflow the stack (SIGSEGV). Nesting is checked on the raw text first, skipping
/// strings and comments. Returns the line where it exceeds `max_depth`, or 0.
std::size_t line_of_excess_nesting(const std::string& t, int max_depth) {
  std::size_t line = 1;
  int depth = 0;
  for (std::size_t i = 0; i < t.size(); ++i) {
    const char c = t[i];
    if (c == '\n') {
      ++line;
    } else if (c == '#') {
      while (i + 1 < t.size() && t[i + 1] != '\n') ++i;
    } else if (c == '"' || c == '\'') {
      const bool multi = t.compare(i, 3, std::string(3, c)) == 0;
      i += multi ? 3 : 1;
      for (; i < t.size(); ++i) {
        if (t[i] == '\n') {
          ++line;
          if (!multi) break;  // an unterminated string: the parser reports it
        } else if (c == '"' && t[i] == '\\') {
          ++i;
        } else if (t[i] == c && (!multi || t.compare(i, 3, std::string(3, c)) == 0)) {
          if (multi) i += 2;
          break;
        }
      }
    } else if (c == '[' || c == '{') {
      if (++depth > max_depth) return line;
    } else if (c == ']' || c == '}') {
      depth = std::max(0, depth - 1);
    }
  }
  return 0;
}

}  // namespace

std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j)
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] != b[j - 1])});
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

TomlConfig TomlConfig::parse(const std::string& text, const std::string& source) {
  // TOML is UTF-8. Invalid bytes are refused before parsing: the parser (toml11 3.7)
  // reads past its buffer on some of them (found by fuzzing, ASan heap-buffer-overflow).
  // The parser's cost grows with the square of a line's length (toml11 3.7 rescans the
  // line for every value on it: a list of 40 000 numbers on one line took 3.9 s, 100 000
  // took 23 s). No configuration needs lines this long.
  constexpr std::size_t kMaxLine = 65536;
  {
    std::size_t line = 1, line_start = 0;
    auto check_line = [&](std::size_t end) {
      if (end - line_start > kMaxLine)
        throw ConfigError(fmt::format("{}:{}: a line of {} characters; at most {} (a list this long is no "
                                      "configuration: grids take at most 1000 points)",
                                      source, line, end - line_start, kMaxLine));
    };
    for (std::size_t i = 0; i < text.size();) {
      const auto c = static_cast<unsigned char>(text[i]);
      if (c == '\n') {
        check_line(i);
        ++line;
        line_start = i + 1;
      }
      std::size_t len = c < 0x80 ? 1 : (c >> 5) == 0x6 ? 2 : (c >> 4) == 0xE ? 3 : (c >> 3) == 0x1E ? 4 : 0;
      bool ok = len > 0 && i + len <= text.size() && !(c == 0xC0 || c == 0xC1 || c > 0xF4);
      for (std::size_t k = 1; ok && k < len; ++k) ok = (static_cast<unsigned char>(text[i + k]) >> 6) == 0x2;
      if (!ok)
        throw ConfigError(fmt::format("{}:{}: byte 0x{:02X} is not valid UTF-8; TOML files are UTF-8 text",
                                      source, line, c));
      i += len;
    }
    check_line(text.size());
  }
  constexpr int kMaxNesting = 64;
  if (const std::size_t bad = line_of_excess_nesting(text, kMaxNesting))
    throw ConfigError(fmt::format("{}:{}: arrays or inline tables nested deeper than {} levels; expected "
                                  "a flat configuration",
                                  source, bad, kMaxNesting));
  toml::value root;
  try {
    std::istringstream in(text);
    root = toml::parse(in, source);
  } catch (const toml::exception& e) {
    throw ConfigError(fmt::format("{}:{}: TOML syntax error: {}", source, e.location().line(),
                                  first_line(e.what())));
  }
  TomlConfig cfg;
  cfg.source_ = source;
  // Flatten tables into dotted keys.
  struct Item {
    std::string prefix;
    const toml::value* value;
  };
  std::vector<Item> stack{{"", &root}};
  while (!stack.empty()) {
    Item item = stack.back();
    stack.pop_back();
    for (const auto& [k, v] : item.value->as_table()) {
      const std::string key = item.prefix.empty() ? k : item.prefix + "." + k;
      if (v.is_table()) {
        stack.push_back({key, &v});
        continue;
      }
      Entry e;
      e.type = type_name(v);
      e.line = v.location().line();
      if (v.is_array()) {
        e.is_array = true;
        for (const auto& el : v.as_array()) e.texts.push_back(scalar_text(el, source, key));
      } else {
        e.texts.push_back(scalar_text(v, source, key));
      }
      cfg.entries_.emplace(key, std::move(e));
    }
  }
  return cfg;
}

TomlConfig TomlConfig::load(const std::filesystem::path& path) {
  // The parser keeps about 100 bytes per value: 64 MiB of text (2e6 beads' positions
  // and more) stays well inside a gigabyte.
  constexpr std::uintmax_t kMaxBytes = 64u << 20;
  std::error_code ec;
  if (const auto size = std::filesystem::file_size(path, ec); !ec && size > kMaxBytes)
    throw InputError(fmt::format("{}: config file of {} bytes: expected at most 64 MiB", path.string(), size));
  return parse(read_file_bytes(path, "config file"), path.string());
}

std::vector<std::string> TomlConfig::keys() const {
  std::vector<std::string> out;
  for (const auto& kv : entries_) out.push_back(kv.first);
  return out;
}

std::size_t TomlConfig::line(const std::string& key) const {
  auto it = entries_.find(key);
  return it == entries_.end() ? 0 : it->second.line;
}

std::string TomlConfig::where(const std::string& key) const {
  return fmt::format("{}:{}: key \"{}\"", source_, line(key), key);
}

const TomlConfig::Entry& TomlConfig::entry(const std::string& key) const {
  auto it = entries_.find(key);
  if (it == entries_.end())
    throw ConfigError(fmt::format("{}: missing key \"{}\"", source_, key));
  return it->second;
}

const std::vector<std::string>& TomlConfig::texts(const std::string& key) const {
  return entry(key).texts;
}

bool TomlConfig::is_array(const std::string& key) const { return entry(key).is_array; }

double TomlConfig::get_double(const std::string& key) const {
  const Entry& e = entry(key);
  double v = 0;
  if (e.is_array || (e.type != "integer" && e.type != "float") ||
      !parse_number(e.texts[0], false, v))
    throw ConfigError(fmt::format("{}: {} value is not allowed; expected a number", where(key),
                                  e.type));
  return v;
}

long long TomlConfig::get_int(const std::string& key) const {
  const Entry& e = entry(key);
  if (e.is_array || e.type != "integer")
    throw ConfigError(fmt::format("{}: {} value is not allowed; expected an integer",
                                  where(key), e.type));
  return std::stoll(e.texts[0]);
}

std::string TomlConfig::get_string(const std::string& key) const {
  const Entry& e = entry(key);
  if (e.is_array || e.type != "string")
    throw ConfigError(fmt::format("{}: {} value is not allowed; expected a string", where(key),
                                  e.type));
  return e.texts[0];
}

bool TomlConfig::get_bool(const std::string& key) const {
  const Entry& e = entry(key);
  if (e.is_array || e.type != "boolean")
    throw ConfigError(fmt::format("{}: {} value is not allowed; expected true or false",
                                  where(key), e.type));
  return e.texts[0] == "true";
}

std::vector<double> TomlConfig::get_doubles(const std::string& key) const {
  std::vector<double> out;
  for (const std::string& t : texts(key)) {
    double v = 0;
    if (!parse_number(t, false, v) || !std::isfinite(v))
      fail(key, fmt::format("\"{}\" is not a finite number (expected a number or a list of numbers)", t));
    out.push_back(v);
  }
  return out;
}

void TomlConfig::fail(const std::string& key, const std::string& what) const {
  throw ConfigError(fmt::format("{}: {}", where(key), what));
}

void TomlConfig::require_known(const std::vector<std::string>& known) const {
  for (const auto& [key, e] : entries_) {
    if (std::find(known.begin(), known.end(), key) != known.end()) continue;
    std::string best;
    std::size_t best_d = 3;  // suggest only close matches (up to 2 edits)
    for (const auto& k : known) {
      const std::size_t d = edit_distance(key, k);
      if (d < best_d) {
        best_d = d;
        best = k;
      }
    }
    std::vector<std::string> sorted = known;
    std::sort(sorted.begin(), sorted.end());
    std::string list;
    for (const auto& k : sorted) list += (list.empty() ? "" : ", ") + k;
    throw ConfigError(fmt::format("{}:{}: unknown key \"{}\"{}; expected one of: {}", source_,
                                  e.line, key,
                                  best.empty() ? "" : fmt::format(" (did you mean \"{}\"?)", best),
                                  list));
  }
}

}  // namespace shearzone::io
