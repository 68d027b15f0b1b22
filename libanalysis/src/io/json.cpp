#include "shearzone/io/json.hpp"

#include <cmath>

#include <fmt/format.h>

#include "shearzone/io/csv.hpp"

namespace shearzone::io {

std::string json_string(std::string_view s) {
  std::string o = "\"";
  for (const char c : s) {
    switch (c) {
      case '"': o += "\\\""; break;
      case '\\': o += "\\\\"; break;
      case '\n': o += "\\n"; break;
      case '\t': o += "\\t"; break;
      case '\r': o += "\\r"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) o += fmt::format("\\u{:04x}", static_cast<unsigned>(c));
        else o += c;
    }
  }
  return o + "\"";
}

std::string json_number(double v) { return std::isfinite(v) ? format_number(v) : std::string("null"); }

std::string json_list(const std::vector<std::string>& items) {
  std::string o = "[";
  for (std::size_t i = 0; i < items.size(); ++i) o += (i ? ", " : "") + json_string(items[i]);
  return o + "]";
}

}  // namespace shearzone::io
