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
    if (!cells[k].empty()) {
      if (!value.empty()) value += ' ';
      value += cells[k];
    }
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
  constexpr double kGramCentimetre = 9.80665e-5;  // N m (gram-force centimetre)
  static const std::array<Entry, 10> kStress{{{"", 1},
                                             {"Pa/gcm", 1 / kGramCentimetre},
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
                                 "Pa/(N·m), 1/m^3), Pa/mN.m, Pa/µN.m, kPa/N.m, MPa/N.m, Pa/g.cm",
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
  // The text export separates cells by TAB, its CSV twin by ','.
  char sep = '\t';
  {
    std::size_t tabs = 0, commas = 0;
    for (std::size_t k = 0; k < std::min<std::size_t>(lines.size(), 50); ++k) {
      tabs += lines[k].text.find('\t') != std::string_view::npos ? 1 : 0;
      commas += lines[k].text.find(',') != std::string_view::npos ? 1 : 0;
    }
    if (tabs == 0 && commas > 0) sep = ',';
  }
  const bool decimal_comma = sep != ',';
  auto cells_of = [&](std::string_view line) { return split_cells(line, sep); };
  auto has_sep = [&](std::string_view line) { return line.find(sep) != std::string_view::npos; };
  std::size_t steps = 0;
  std::string first_error;
  std::size_t i = 0;
  while (i < lines.size()) {
    const std::string_view l = trim(lines[i].text);
    if (l.empty()) {
      ++i;
      continue;
    }
    const bool section = is_section_header(l) && !has_sep(l);
    if (!section || fold(l.substr(1, l.size() - 2)) != "step") {
      if (!section) {
        // A name/value line (of a [Section] or before the first one).
        const auto cells = cells_of(lines[i].text);
        if (!cells.empty() && !cells[0].empty()) {
          const std::string f = fold(split_bracketed_unit(cells[0]).first);
          // A constant in a unit not known here is kept as text: it matters only with
          // --log-constants (which then says that the log gives no usable constant).
          auto constant = [&](bool stress, const char* key) {
            try {
              log.parameters.emplace_back(key, format_number(trios_constant(cells, stress, src, lines[i].number)));
            } catch (const InputError& e) {
              log.parameters.emplace_back(std::string(key) + "_unparsed", e.what());
            }
          };
          if (f == "stress constant") constant(true, "stress_constant_Pa_per_N_m");
          if (f == "strain constant") constant(false, "strain_constant_per_rad");
          std::string value;
          for (std::size_t k = 1; k < cells.size(); ++k)
            if (!cells[k].empty()) {
      if (!value.empty()) value += ' ';
      value += cells[k];
    }
          log.parameters.emplace_back(std::string(cells[0]), value);
        }
      }
      ++i;
      continue;
    }
    // A step: optional name line, header row, units row, data rows. The "LIMS export
    // format" writes them as key rows: "Step name", "Number of points", "Variables",
    // "Units", "Data point".
    ++steps;
    const std::size_t step_line = lines[i].number;
    ++i;
    auto skip_blank = [&] {
      while (i < lines.size() && trim(lines[i].text).empty()) ++i;
    };
    skip_blank();
    LogSegment seg;
    seg.label = std::to_string(steps);
    auto first_key = [&](std::size_t k) {
      return k < lines.size() ? fold(cells_of(lines[k].text)[0]) : std::string();
    };
    if (i < lines.size() && !has_sep(lines[i].text) && !is_section_header(lines[i].text)) {
      seg.label = std::string(trim(lines[i].text));
      ++i;
      skip_blank();
    }
    while (i < lines.size() && (first_key(i) == "step name" || first_key(i) == "number of points")) {
      if (first_key(i) == "step name") {
        const auto c = cells_of(lines[i].text);
        if (c.size() > 1 && !c[1].empty()) seg.label = std::string(c[1]);
      }
      ++i;
    }
    auto skip = [&](const std::string& why, const std::string& error) {
      log.skipped.push_back(fmt::format("{} (line {}): {}", seg.label, step_line, why));
      if (first_error.empty()) first_error = error;
      while (i < lines.size() && !is_section_header(lines[i].text)) ++i;
    };
    if (i >= lines.size() || is_section_header(lines[i].text)) {
      skip("no header row", fmt::format("{}:{}: [step] block without a header row", src, step_line));
      continue;
    }
    auto header = cells_of(lines[i].text);
    const bool lims = fold(header[0]) == "variables";
    if (lims) header.erase(header.begin());
    std::size_t header_line = lines[i].number;
    std::vector<std::vector<std::string>> alts;
    std::vector<std::string> units(header.size()), shown;
    for (std::size_t k = 0; k < header.size(); ++k) {
      auto [n, u] = split_bracketed_unit(header[k]);
      alts.push_back({n});
      shown.push_back(n);
      units[k] = u;
    }
    ++i;
    skip_blank();
    if (i < lines.size()) {
      auto row = cells_of(lines[i].text);
      if (lims && fold(row[0]) == "units") row.erase(row.begin());
      if (!std::any_of(row.begin(), row.end(), is_number) && !is_section_header(lines[i].text)) {
        for (std::size_t k = 0; k < row.size() && k < units.size(); ++k)
          if (!row[k].empty()) units[k] = std::string(row[k]);
        header_line = lines[i].number;
        ++i;
      }
    }
    // A step of results per point (G', G'') holds amplitudes, not a waveform.
    if (find_localised(alts, {"storage modulus", "loss modulus"})) {
      skip("no raw waveform, one row per point (storage and loss moduli) with columns " +
               list_names(shown),
           fmt::format("{}:{}: step \"{}\" holds results per point (columns {}), no raw "
                       "waveform; shearzone laos needs the drive and response samples",
                       src, header_line, seg.label, list_names(shown)));
      continue;
    }
    std::optional<VendorColumns> vc;
    try {
      vc = resolve_vendor_columns(alts, units, o, src, header_line);
    } catch (const InputError& e) {
      skip("no drive and response columns among " + list_names(shown), e.what());
      continue;
    }
    bool bad = false;
    while (i < lines.size()) {
      if (is_section_header(lines[i].text)) break;
      auto row = cells_of(lines[i].text);
      if (all_empty(row)) {
        ++i;
        continue;
      }
      if (lims && fold(row[0]) == "data point") row.erase(row.begin());
      try {
        append_sample(seg, row, vc->time, vc->drive, vc->response, decimal_comma, src, lines[i].number);
      } catch (const InputError& e) {
        // A damaged cell in a waveform step (text, empty, overflowing, a thousands
        // separator, a stray byte-order mark) is refused with its line, never dropped;
        // --inspect lists it instead.
        if (!o.inspect) throw;
        skip(std::string("unreadable samples: ") + e.what(), e.what());
        bad = true;
        break;
      }
      ++i;
    }
    if (bad) continue;
    if (seg.drive.empty()) {
      skip("no data rows", fmt::format("{}:{}: step \"{}\" has no data rows", src, step_line, seg.label));
      continue;
    }
    if (!vc->time) note_no_time(log);
    if (vc->time) check_time(seg, src, vc->time->name);
    log.segments.push_back(std::move(seg));
  }
  if (log.segments.empty() && !o.inspect && steps > 0)
    refuse_without_waveform(log, steps, "step", first_error, "");
}

}  // namespace shearzone::io::log_detail
