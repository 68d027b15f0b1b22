// RepTate .laos files.
#include "log_common.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <string_view>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/core/metadata.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/io/file.hpp"

namespace shearzone::io::log_detail {

void read_reptate(std::string_view text, const LogReadOptions& o, OscillationLog& log) {
  no_interval_column(o, "RepTate");
  const auto lines = split_lines(text);
  const std::string& src = log.source;
  std::size_t i = 0;
  while (i < lines.size() && trim(lines[i].text).empty()) ++i;
  if (i == lines.size()) throw InputError(fmt::format("{}: empty file", src));
  // Header: key=value;key=value;
  {
    const std::size_t hl = lines[i].number;
    std::string_view h = trim(lines[i].text);
    std::size_t pos = 0;
    while (pos < h.size()) {
      std::size_t end = h.find(';', pos);
      if (end == std::string_view::npos) end = h.size();
      const std::string_view kv = trim(h.substr(pos, end - pos));
      pos = end + 1;
      if (kv.empty()) continue;
      const std::size_t eq = kv.find('=');
      if (eq == std::string_view::npos)
        throw InputError(fmt::format("{}:{}: \"{}\" is not key=value; expected a RepTate "
                                     "header like omega=3.0;gamma=1.0;",
                                     src, hl, kv));
      const std::string key(trim(kv.substr(0, eq)));
      const std::string value(trim(kv.substr(eq + 1)));
      double x = 0;
      if (key == "omega" || key == "gamma") {
        if (!parse_number(value, false, x) || !std::isfinite(x))
          throw InputError(fmt::format("{}:{}: {}: \"{}\" is not a number", src, hl, key, value));
        log.parameters.emplace_back(key == "omega" ? "omega_rad_per_s" : "gamma0", value);
      } else {
        log.parameters.emplace_back(key, value);
      }
    }
    ++i;
  }
  // Comment rows: names (maybe with "(unit)"), then maybe a units row.
  std::vector<std::vector<std::string_view>> comments;
  std::size_t data_start = i;
  while (data_start < lines.size()) {
    const std::string_view l = trim(lines[data_start].text);
    if (l.empty()) {
      ++data_start;
      continue;
    }
    if (l.front() != '#') break;
    comments.push_back(split_whitespace(l.substr(1)));
    ++data_start;
  }
  std::array<std::string, 3> names{"time", "strain", "stress"};
  std::array<std::string, 3> units{"", "", ""};
  std::array<bool, 3> has_unit{false, false, false};
  if (!comments.empty()) {
    for (std::size_t k = 0; k < 3 && k < comments[0].size(); ++k) {
      auto [n, u] = split_bracketed_unit(comments[0][k]);
      names[k] = n;
      if (comments[0][k].back() == ')' || comments[0][k].back() == ']') {
        units[k] = u;
        has_unit[k] = true;
      }
    }
    if (comments.size() >= 2)
      for (std::size_t k = 0; k < 3 && k < comments[1].size(); ++k) {
        units[k] = std::string(comments[1][k]);
        has_unit[k] = true;
      }
  }
  // The quantity follows the file's units (RepTate's convention: strain, stress in Pa).
  const std::string where =
      fmt::format("{}:{}", src, data_start > 0 ? lines[data_start - 1].number : 1);
  LogQuantity q = LogQuantity::kStrainStress;
  if (has_unit[1] && find_unit_scale(units[1], UnitKind::kAngle)) q = LogQuantity::kAngleTorque;
  if (!has_unit[1] && has_unit[2] && find_unit_scale(units[2], UnitKind::kTorque))
    q = LogQuantity::kAngleTorque;
  log.quantity = q;
  LogReadOptions ro = o;
  ro.quantity = q;
  if (!has_unit[2] && q == LogQuantity::kAngleTorque && o.torque_unit.empty())
    throw InputError(fmt::format("{}: column \"{}\" has no unit; expected a torque unit ({}) "
                                 "since the angle is in {}",
                                 where, names[2], accepted_units(UnitKind::kTorque), units[1]));
  // Without a unit: RepTate's convention (s, dimensionless strain, Pa).
  const Column time{0, names[0],
                    column_scale(ro, UnitKind::kTime, has_unit[0] ? units[0] : "s", true, where,
                                 names[0])};
  const Column drive{1, names[1],
                     column_scale(ro, drive_kind(q), units[1], true, where, names[1])};
  const Column response{2, names[2],
                        column_scale(ro, response_kind(q), has_unit[2] ? units[2] : "Pa", true,
                                     where, names[2])};
  LogSegment seg;
  seg.label = "1";
  for (i = data_start; i < lines.size(); ++i) {
    const std::string_view l = trim(lines[i].text);
    if (l.empty() || l.front() == '#') continue;
    const auto cells = split_whitespace(l);
    append_sample(seg, cells, time, drive, response, false, src, lines[i].number);
  }
  check_time(seg, src, time.name);
  log.segments.push_back(std::move(seg));
}

}  // namespace shearzone::io::log_detail
