// Anton Paar RheoCompass exports (English, German, French user interfaces).
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

void read_anton_paar(std::string_view text, const LogReadOptions& o, OscillationLog& log) {
  no_interval_column(o, "RheoCompass");
  const auto lines = split_lines(text);
  const std::string& src = log.source;
  std::size_t i = 0, interval_number = 0;
  auto add_parameter = [&](const std::vector<std::string_view>& cells) {
    std::string key, value;
    for (auto c : cells) {
      if (c.empty()) continue;
      if (key.empty()) {
        key = std::string(c);
      } else {
        value += (value.empty() ? "" : " ") + std::string(c);
      }
    }
    if (!key.empty() && key.back() == ':') key.pop_back();
    if (!key.empty()) log.parameters.emplace_back(std::string(trim(key)), value);
  };

  while (i < lines.size()) {
    const auto cells = split_cells(lines[i].text, '\t');
    const std::size_t first = first_nonempty(cells);
    if (first == cells.size()) {
      ++i;
      continue;
    }
    if (!is_interval_marker(cells[first])) {
      add_parameter(cells);
      ++i;
      continue;
    }
    // An interval: names on the marker line (after the marker) or on the next line.
    const std::size_t marker_line = lines[i].number;
    std::vector<std::vector<std::string>> alts;
    std::vector<std::string> units;
    std::vector<std::string_view> name_cells(cells.begin(), cells.end());
    name_cells[first] = "";
    ++i;
    if (all_empty(name_cells)) {
      while (i < lines.size() && trim(lines[i].text).empty()) ++i;
      if (i == lines.size())
        throw InputError(fmt::format("{}:{}: \"Interval data:\" line without column names",
                                     src, marker_line));
      name_cells = split_cells(lines[i].text, '\t');
      ++i;
    }
    std::size_t header_line = i > 0 ? lines[i - 1].number : marker_line;
    for (auto c : name_cells) {
      auto [n, u] = split_bracketed_unit(c);
      alts.push_back({n});
      units.push_back(u);
    }
    // Further name rows, then the units row.
    while (i < lines.size()) {
      const auto row = split_cells(lines[i].text, '\t');
      if (all_empty(row)) {
        ++i;
        continue;
      }
      const bool any_number = std::any_of(row.begin(), row.end(), is_number);
      if (any_number) break;
      bool units_row = true;
      for (auto c : row) units_row &= c.empty() || is_bracketed(c);
      if (alts.size() < row.size()) {
        alts.resize(row.size());
        units.resize(row.size());
      }
      for (std::size_t k = 0; k < row.size(); ++k) {
        if (row[k].empty()) continue;
        if (units_row) {
          units[k] = std::string(row[k].substr(1, row[k].size() - 2));
        } else {
          // A second name row: the column is known by the joined name and either part.
          const std::string joined =
              alts[k].empty() || alts[k].front().empty()
                  ? std::string(row[k])
                  : alts[k].front() + " " + std::string(row[k]);
          alts[k].insert(alts[k].begin(), joined);
          alts[k].emplace_back(row[k]);
        }
      }
      header_line = lines[i].number;
      ++i;
      if (units_row) break;
    }
    const VendorColumns vc = resolve_vendor_columns(alts, units, o, src, header_line);
    LogSegment seg;
    seg.label = std::to_string(++interval_number);
    while (i < lines.size()) {
      const auto row = split_cells(lines[i].text, '\t');
      const std::size_t f = first_nonempty(row);
      if (f == row.size()) {
        ++i;
        continue;
      }
      // A first cell that is text (not a number) ends the data: a new interval or a
      // name/value line.
      if (f == 0 && !is_number(row[0])) break;
      append_sample(seg, row, vc.time, vc.drive, vc.response, true, src, lines[i].number);
      ++i;
    }
    if (seg.drive.empty()) {
      // An interval without raw data (a rest or pre-shear step): noted, not a segment.
      log.parameters.emplace_back(
          "empty_interval", fmt::format("{} (line {}: no data rows)", seg.label, marker_line));
      continue;
    }
    if (!vc.time) note_no_time(log);
    if (vc.time) check_time(seg, src, vc.time->name);
    log.segments.push_back(std::move(seg));
  }
}

}  // namespace shearzone::io::log_detail
