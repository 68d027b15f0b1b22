// TA Instruments TRIOS text exports.
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
namespace {

/// "31.83 Pa/N.m" (or number and unit in two cells) as a number in SI, for the
/// stress and strain constants.
double trios_constant(const std::vector<std::string_view>& cells, bool stress,
                      const std::string& src, std::size_t line) {
  std::string value;
  for (std::size_t k = 1; k < cells.size(); ++k)
    if (!cells[k].empty()) value += (value.empty() ? "" : " ") + std::string(cells[k]);
  std::string name(cells[0]);
  auto [bare_name, name_unit] = split_bracketed_unit(name);
  std::string_view v = trim(value);
  std::size_t split = v.find(' ');
  std::string number(split == std::string_view::npos ? v : v.substr(0, split));
  std::string unit(split == std::string_view::npos ? std::string_view() : trim(v.substr(split)));
  if (unit.empty()) unit = name_unit;
  double x = 0;
  if (!parse_number(number, true, x) || !std::isfinite(x))
    throw InputError(fmt::format("{}:{}: \"{}\": \"{}\" is not a number", src, line, bare_name,
                                 value));
  std::string u;
  for (char c : unit)
    if (c != ' ' && c != '.' && c != '(' && c != ')' && c != '*') u += c;
  // Middle dots and micro signs.
  std::string nu;
  for (std::size_t k = 0; k < u.size(); ++k) {
    if (u.compare(k, 2, "\xC2\xB7") == 0) {
      ++k;
      continue;
    }
    if (u.compare(k, 2, "\xC2\xB5") == 0 || u.compare(k, 2, "\xCE\xBC") == 0) {
      nu += 'u';
      ++k;
      continue;
    }
    nu += u[k];
  }
  struct Entry {
    const char* unit;
    double scale;
  };
  static const std::array<Entry, 9> kStress{{{"", 1},
                                             {"Pa/Nm", 1},
                                             {"1/m^3", 1},
                                             {"m^-3", 1},
                                             {"Pa/mNm", 1e3},
                                             {"Pa/uNm", 1e6},
                                             {"kPa/Nm", 1e3},
                                             {"MPa/Nm", 1e6},
                                             {"1/m3", 1}}};
  static const std::array<Entry, 5> kStrain{
      {{"", 1}, {"1/rad", 1}, {"rad^-1", 1}, {"rad-1", 1}, {"1/mrad", 1e3}}};
  if (stress) {
    for (const auto& e : kStress)
      if (nu == e.unit) return x * e.scale;
    throw InputError(fmt::format("{}:{}: \"{}\": unknown unit \"{}\"; accepted: Pa/N.m (also "
                                 "Pa/(N·m), 1/m^3), Pa/mN.m, Pa/µN.m, kPa/N.m, MPa/N.m",
                                 src, line, bare_name, unit));
  }
  for (const auto& e : kStrain)
    if (nu == e.unit) return x * e.scale;
  throw InputError(fmt::format("{}:{}: \"{}\": unknown unit \"{}\"; accepted: 1/rad (also "
                               "rad^-1), 1/mrad",
                               src, line, bare_name, unit));
}

}  // namespace

void read_trios(std::string_view text, const LogReadOptions& o, OscillationLog& log) {
  no_interval_column(o, "TRIOS");
  const auto lines = split_lines(text);
  const std::string& src = log.source;
  std::size_t i = 0;
  while (i < lines.size()) {
    const std::string_view l = trim(lines[i].text);
    if (l.empty()) {
      ++i;
      continue;
    }
    const bool section = is_section_header(l);
    if (!section || fold(l.substr(1, l.size() - 2)) != "step") {
      if (!section) {
        // A name/value line (of a [Section] or before the first one).
        const auto cells = split_cells(lines[i].text, '\t');
        if (!cells.empty() && !cells[0].empty()) {
          const std::string f = fold(split_bracketed_unit(cells[0]).first);
          if (f == "stress constant")
            log.parameters.emplace_back(
                "stress_constant_Pa_per_N_m",
                format_number(trios_constant(cells, true, src, lines[i].number)));
          if (f == "strain constant")
            log.parameters.emplace_back(
                "strain_constant_per_rad",
                format_number(trios_constant(cells, false, src, lines[i].number)));
          std::string value;
          for (std::size_t k = 1; k < cells.size(); ++k)
            if (!cells[k].empty()) value += (value.empty() ? "" : " ") + std::string(cells[k]);
          log.parameters.emplace_back(std::string(cells[0]), value);
        }
      }
      ++i;
      continue;
    }
    // A step: optional name line, header row, units row, data rows.
    const std::size_t step_line = lines[i].number;
    ++i;
    auto skip_blank = [&] {
      while (i < lines.size() && trim(lines[i].text).empty()) ++i;
    };
    skip_blank();
    LogSegment seg;
    seg.label = std::to_string(log.segments.size() + 1);
    if (i < lines.size() && lines[i].text.find('\t') == std::string_view::npos &&
        !is_section_header(lines[i].text)) {
      seg.label = std::string(trim(lines[i].text));
      ++i;
      skip_blank();
    }
    if (i >= lines.size() || is_section_header(lines[i].text))
      throw InputError(fmt::format("{}:{}: [step] block without a header row", src, step_line));
    const auto header = split_cells(lines[i].text, '\t');
    std::size_t header_line = lines[i].number;
    std::vector<std::vector<std::string>> alts;
    std::vector<std::string> units(header.size());
    for (std::size_t k = 0; k < header.size(); ++k) {
      auto [n, u] = split_bracketed_unit(header[k]);
      alts.push_back({n});
      units[k] = u;
    }
    ++i;
    skip_blank();
    if (i < lines.size()) {
      const auto row = split_cells(lines[i].text, '\t');
      if (!std::any_of(row.begin(), row.end(), is_number) && !is_section_header(lines[i].text)) {
        for (std::size_t k = 0; k < row.size() && k < units.size(); ++k)
          if (!row[k].empty()) units[k] = std::string(row[k]);
        header_line = lines[i].number;
        ++i;
      }
    }
    const VendorColumns vc = resolve_vendor_columns(alts, units, o, src, header_line);
    while (i < lines.size()) {
      if (is_section_header(lines[i].text)) break;
      const auto row = split_cells(lines[i].text, '\t');
      if (all_empty(row)) {
        ++i;
        continue;
      }
      append_sample(seg, row, vc.time, vc.drive, vc.response, true, src, lines[i].number);
      ++i;
    }
    if (seg.drive.empty())
      throw InputError(fmt::format("{}:{}: step \"{}\" has no data rows", src, step_line,
                                   seg.label));
    if (!vc.time) note_no_time(log);
    if (vc.time) check_time(seg, src, vc.time->name);
    log.segments.push_back(std::move(seg));
  }
}

}  // namespace shearzone::io::log_detail
