// shearzone/io/json.hpp: the pieces of JSON our outputs write (camera.json, a study's
// study.json), written once: strings escaped as RFC 8259 requires (quote, backslash,
// control characters), numbers in the shortest form that reads back to the same double.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace shearzone::io {

/// `s` as a JSON string, quotes included: `"`, `\` and control characters escaped.
std::string json_string(std::string_view s);

/// A finite number as JSON (io::format_number); NaN and infinities, which JSON cannot
/// hold, as null.
std::string json_number(double v);

/// A JSON array of strings.
std::string json_list(const std::vector<std::string>& items);

}  // namespace shearzone::io
