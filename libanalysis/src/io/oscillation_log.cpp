// Rheometer oscillation logs: text decoding, format detection, and the four readers
// (generic CSV/TSV, Anton Paar RheoCompass, TA TRIOS, RepTate .laos). Every reader
// produces segments of (time, drive, response) in SI units and checks them the same
// way (finite numbers, increasing time), so that each error names file, line, column.
#include "shearzone/io/oscillation_log.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string_view>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/io/file.hpp"
#include "shearzone/io/units.hpp"

namespace shearzone::io {
namespace {

// ---- Text helpers -----------------------------------------------------------------

std::string_view trim(std::string_view s) {
  auto is_space = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; };
  while (!s.empty() && is_space(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_space(s.back())) s.remove_suffix(1);
  // No-break spaces (U+00A0) that spreadsheet exports put around cells.
  while (s.size() >= 2 && s.substr(0, 2) == "\xC2\xA0") s.remove_prefix(2);
  while (s.size() >= 2 && s.substr(s.size() - 2) == "\xC2\xA0") s.remove_suffix(2);
  return s;
}

struct TextLine {
  std::size_t number;  ///< 1-based
  std::string_view text;  ///< without the line break
};

std::vector<TextLine> split_lines(std::string_view text) {
  std::vector<TextLine> out;
  std::size_t pos = 0, n = 1;
  while (pos < text.size()) {
    std::size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    std::string_view l = text.substr(pos, end - pos);
    if (!l.empty() && l.back() == '\r') l.remove_suffix(1);
    out.push_back({n++, l});
    pos = end + 1;
  }
  return out;
}

std::vector<std::string_view> split_cells(std::string_view line, char sep) {
  std::vector<std::string_view> out;
  std::size_t pos = 0;
  while (true) {
    const std::size_t end = line.find(sep, pos);
    if (end == std::string_view::npos) {
      out.push_back(trim(line.substr(pos)));
      return out;
    }
    out.push_back(trim(line.substr(pos, end - pos)));
    pos = end + 1;
  }
}

std::vector<std::string_view> split_whitespace(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t pos = 0;
  while (pos < line.size()) {
    while (pos < line.size() && (line[pos] == ' ' || line[pos] == '\t')) ++pos;
    if (pos >= line.size()) break;
    std::size_t end = pos;
    while (end < line.size() && line[end] != ' ' && line[end] != '\t') ++end;
    out.push_back(line.substr(pos, end - pos));
    pos = end;
  }
  return out;
}

bool all_empty(const std::vector<std::string_view>& cells) {
  return std::all_of(cells.begin(), cells.end(), [](std::string_view c) { return c.empty(); });
}

/// For matching localised names: ASCII lower case, runs of spaces as one, typographic
/// apostrophes as '.
std::string fold(std::string_view s) {
  s = trim(s);
  std::string out;
  bool space = false;
  for (std::size_t i = 0; i < s.size(); ++i) {
    char c = s[i];
    if (s.substr(i, 3) == "\xE2\x80\x99") {  // ’
      c = '\'';
      i += 2;
    }
    if (c == ' ' || c == '\t') {
      space = true;
      continue;
    }
    if (space && !out.empty()) out += ' ';
    space = false;
    out += (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c;
  }
  return out;
}

bool is_number(std::string_view cell) {
  double v = 0;
  return parse_number(cell, true, v);
}

/// A cell that is a unit in brackets: "[mN·m]".
bool is_bracketed(std::string_view cell) {
  return cell.size() >= 2 && cell.front() == '[' && cell.back() == ']';
}

/// Splits "Torque [mN·m]" or "Strain(-)" into name and unit (without brackets).
std::pair<std::string, std::string> split_bracketed_unit(std::string_view header) {
  header = trim(header);
  if (header.size() >= 2 && (header.back() == ']' || header.back() == ')')) {
    const char open = header.back() == ']' ? '[' : '(';
    const std::size_t p = header.rfind(open);
    if (p != std::string_view::npos && p > 0)
      return {std::string(trim(header.substr(0, p))),
              std::string(header.substr(p + 1, header.size() - p - 2))};
  }
  return {std::string(header), ""};
}

// ---- Samples ----------------------------------------------------------------------

/// A column of the source: where it is, what it is called, its factor to SI.
struct Column {
  std::size_t index = 0;
  std::string name;
  double scale = 1.0;
};

double cell_value(std::string_view cell, bool decimal_comma, const std::string& source,
                  std::size_t line, const std::string& column) {
  cell = trim(cell);
  double v = 0;
  if (cell.empty())
    throw InputError(fmt::format("{}:{}: column \"{}\": missing value (empty cell); expected a "
                                 "number",
                                 source, line, column));
  if (!parse_number(cell, decimal_comma, v))
    throw InputError(fmt::format("{}:{}: column \"{}\": \"{}\" is not a number", source, line,
                                 column, cell));
  if (!std::isfinite(v))
    throw InputError(fmt::format("{}:{}: column \"{}\": \"{}\" is not a finite number", source,
                                 line, column, cell));
  return v;
}

/// The cell of `col` in a row, or an InputError if the row is too short.
std::string_view cell_of(const std::vector<std::string_view>& cells, const Column& col,
                         const std::string& source, std::size_t line) {
  if (col.index >= cells.size())
    throw InputError(fmt::format("{}:{}: column \"{}\": missing value (the row has {} "
                                 "field{}); expected a number",
                                 source, line, col.name, cells.size(),
                                 cells.size() == 1 ? "" : "s"));
  return cells[col.index];
}

/// Appends one sample read from `cells`.
void append_sample(LogSegment& seg, const std::vector<std::string_view>& cells,
                   const std::optional<Column>& time, const Column& drive,
                   const Column& response, bool decimal_comma, const std::string& source,
                   std::size_t line) {
  if (time)
    seg.time_s.push_back(
        cell_value(cell_of(cells, *time, source, line), decimal_comma, source, line, time->name) *
        time->scale);
  seg.drive.push_back(
        cell_value(cell_of(cells, drive, source, line), decimal_comma, source, line, drive.name) *
        drive.scale);
  seg.response.push_back(cell_value(cell_of(cells, response, source, line), decimal_comma,
                                    source, line, response.name) *
                         response.scale);
  seg.line.push_back(line);
}

/// Time must increase strictly within a segment.
void check_time(const LogSegment& seg, const std::string& source, const std::string& column) {
  for (std::size_t i = 1; i < seg.time_s.size(); ++i)
    if (!(seg.time_s[i] > seg.time_s[i - 1]))
      throw InputError(fmt::format(
          "{}:{}: column \"{}\": time {} s does not increase (previous sample, line {}: {} s); "
          "expected strictly increasing time within a segment",
          source, seg.line[i], column, seg.time_s[i], seg.line[i - 1], seg.time_s[i - 1]));
}

UnitKind drive_kind(LogQuantity q) {
  return q == LogQuantity::kAngleTorque ? UnitKind::kAngle : UnitKind::kStrain;
}
UnitKind response_kind(LogQuantity q) {
  return q == LogQuantity::kAngleTorque ? UnitKind::kTorque : UnitKind::kStress;
}

/// The user's unit override for a kind (empty: none).
const std::string& unit_override(const LogReadOptions& o, UnitKind kind) {
  if (kind == UnitKind::kTime) return o.time_unit;
  if (kind == UnitKind::kAngle || kind == UnitKind::kStrain) return o.angle_unit;
  return o.torque_unit;
}

/// Scale of a column: the override, else the unit found in the file, else an error.
double column_scale(const LogReadOptions& o, UnitKind kind, const std::string& file_unit,
                    bool file_has_unit, const std::string& where, const std::string& column) {
  const std::string& over = unit_override(o, kind);
  if (!over.empty()) {
    const char* option = kind == UnitKind::kTime ? "time_unit"
                         : (kind == UnitKind::kAngle || kind == UnitKind::kStrain)
                             ? "angle_unit"
                             : "torque_unit";
    return parse_unit(over, kind, fmt::format("option {}", option));
  }
  if (file_has_unit) return parse_unit(file_unit, kind, fmt::format("{}: column \"{}\"", where, column));
  throw InputError(fmt::format("{}: column \"{}\" has no unit; give it in the header "
                               "(\"{} [unit]\" or a name suffix like {}) or with the {} unit "
                               "option; accepted: {}",
                               where, column, column,
                               kind == UnitKind::kTime     ? "time_s"
                               : kind == UnitKind::kAngle  ? "angle_rad"
                               : kind == UnitKind::kTorque ? "torque_N_m"
                               : kind == UnitKind::kStrain ? "strain_pct"
                                                           : "stress_Pa",
                               unit_kind_name(kind), accepted_units(kind)));
}

/// One error for every column that has neither a unit in the file nor an override:
/// each with the option that gives it.
struct UnitNeed {
  UnitKind kind;
  std::string column;
  bool has_unit;
};
void require_units(const LogReadOptions& o, const std::vector<UnitNeed>& needs, const std::string& where) {
  std::string missing;
  for (const auto& n : needs) {
    if (n.has_unit || !unit_override(o, n.kind).empty()) continue;
    const char* option = n.kind == UnitKind::kTime                                     ? "--time-unit"
                         : (n.kind == UnitKind::kAngle || n.kind == UnitKind::kStrain) ? "--angle-unit"
                                                                                        : "--torque-unit";
    missing += fmt::format("{}\"{}\" ({} {})", missing.empty() ? "" : ", ", n.column, option,
                           accepted_units(n.kind));
  }
  if (!missing.empty())
    throw InputError(fmt::format("{}: column{} without a unit: {}; give each with its option, or in "
                                 "the header (\"time [s]\", time_s, angle_rad, torque_N_m)",
                                 where, missing.find(", \"") == std::string::npos ? "" : "s", missing));
}

bool parse_plain_number(std::string_view s, double& v) { return parse_number(s, true, v); }

/// Fills the convenience lookups from `parameters`.
void finish(OscillationLog& log) {
  auto lookup = [&](const char* key, double& out) {
    const std::string v = core::metadata_value(log.parameters, key);
    double x = 0;
    if (!v.empty() && parse_plain_number(v, x)) out = x;
  };
  lookup("omega_rad_per_s", log.omega_rad_per_s);
  lookup("stress_constant_Pa_per_N_m", log.stress_constant_Pa_per_N_m);
  lookup("strain_constant_per_rad", log.strain_constant_per_rad);
  if (log.segments.empty())
    throw InputError(fmt::format("{}: no data rows found; expected at least one sample",
                                 log.source));
  for (const auto& s : log.segments)
    if (s.drive.empty())
      throw InputError(fmt::format("{}: segment \"{}\" has no data rows", log.source, s.label));
}

std::string list_names(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names)
    if (!n.empty()) out += (out.empty() ? "\"" : ", \"") + excerpt(n, 60) + "\"";
  return excerpt(out, 300);  // a message quotes a bounded part of the input
}

// ---- Localised column names (Anton Paar, TRIOS) -----------------------------------

constexpr std::array<std::string_view, 3> kIntervalMarkers{
    "interval data:", "intervalldaten:", "donn\xC3\xA9" "es d'intervalle:"};

bool is_interval_marker(std::string_view first_cell) {
  const std::string f = fold(first_cell);
  for (auto m : kIntervalMarkers)
    if (f == m || f + ":" == m) return true;
  return false;
}

const std::vector<std::string>& time_names() {
  static const std::vector<std::string> v{
      "time", "zeit", "temps", "interval time", "intervallzeit", "temps d'intervalle",
      "temps de l'intervalle", "step time", "test time", "versuchszeit", "temps d'essai"};
  return v;
}
const std::vector<std::string>& angle_names() {
  static const std::vector<std::string> v{
      "deflection angle", "auslenkwinkel", "angle de d\xC3\xA9viation", "angle de deviation",
      "oscillation displacement", "displacement", "angular displacement",
      "oscillation angular displacement"};
  return v;
}
const std::vector<std::string>& torque_names() {
  static const std::vector<std::string> v{"torque", "drehmoment", "couple",
                                          "oscillation torque"};
  return v;
}
const std::vector<std::string>& strain_names() {
  static const std::vector<std::string> v{
      "strain", "shear strain", "deformation", "scherdeformation", "d\xC3\xA9" "formation",
      "d\xC3\xA9" "formation de cisaillement", "oscillation strain"};
  return v;
}
const std::vector<std::string>& stress_names() {
  static const std::vector<std::string> v{"shear stress", "stress", "schubspannung",
                                          "contrainte de cisaillement", "contrainte",
                                          "oscillation stress"};
  return v;
}

/// Index of the first header (in candidate order) whose folded name is one of the
/// candidates; `alternatives[i]` holds the names under which header i may be found.
std::optional<std::size_t> find_localised(const std::vector<std::vector<std::string>>& alts,
                                          const std::vector<std::string>& candidates) {
  // Each name is folded once and looked up (linear in the header's size: a fuzzed
  // header of thousands of cells and lines took > 10 s when every candidate refolded
  // every name).
  std::size_t best_rank = candidates.size();
  std::optional<std::size_t> best;
  for (std::size_t i = 0; i < alts.size(); ++i)
    for (const auto& a : alts[i]) {
      if (a.size() > 256) continue;  // no column name is that long
      const std::string f = fold(a);
      const auto it = std::find(candidates.begin(), candidates.end(), f);
      const auto rank = static_cast<std::size_t>(it - candidates.begin());
      if (rank < best_rank) {  // candidate order first, then the first header
        best_rank = rank;
        best = i;
      }
    }
  return best;
}

/// Which column of a vendor table holds a quantity: the user's name if it differs
/// from the default, else the localised names.
std::optional<std::size_t> find_vendor_column(const std::vector<std::vector<std::string>>& alts,
                                              const std::string& option,
                                              const std::string& default_name,
                                              const std::vector<std::string>& candidates) {
  if (option != default_name) {
    for (std::size_t i = 0; i < alts.size(); ++i)
      for (const auto& a : alts[i])
        if (fold(a) == fold(option)) return i;
    return std::nullopt;
  }
  return find_localised(alts, candidates);
}

/// Resolves the time/drive/response columns of a vendor table (names per position,
/// units per position, "" when absent). Returns false for time when there is none.
struct VendorColumns {
  std::optional<Column> time;
  Column drive, response;
};

VendorColumns resolve_vendor_columns(const std::vector<std::vector<std::string>>& alts,
                                     const std::vector<std::string>& units,
                                     const LogReadOptions& o, const std::string& source,
                                     std::size_t header_line) {
  const LogReadOptions defaults;
  const bool strain = o.quantity == LogQuantity::kStrainStress;
  std::vector<std::string> shown;
  for (const auto& a : alts) shown.push_back(a.empty() ? "" : a.front());
  const std::string where = fmt::format("{}:{}", source, header_line);

  auto unit_at = [&](std::size_t i) { return i < units.size() ? units[i] : std::string(); };
  auto make = [&](std::size_t i, UnitKind kind) {
    Column c;
    c.index = i;
    c.name = shown[i];
    const std::string u = unit_at(i);
    c.scale = column_scale(o, kind, u, !u.empty() || kind == UnitKind::kStrain, where, c.name);
    return c;
  };
  auto require = [&](std::optional<std::size_t> i, const char* what,
                     const std::vector<std::string>& cands, const std::string& option,
                     const std::string& def) {
    if (i) return *i;
    std::string expected;
    if (option != def) {
      expected = "\"" + option + "\"";
    } else {
      for (const auto& c : cands) expected += (expected.empty() ? "\"" : ", \"") + c + "\"";
    }
    throw InputError(fmt::format("{}: no {} column (looked for {}); the header has: {}", where,
                                 what, expected, list_names(shown)));
  };

  VendorColumns vc;
  const auto ti = find_vendor_column(alts, o.time_column, defaults.time_column, time_names());
  if (!ti && o.time_column != defaults.time_column && !o.time_column.empty()) {
    require(ti, "time", time_names(), o.time_column, defaults.time_column);
  }
  const auto di = require(
      find_vendor_column(alts, o.angle_column, defaults.angle_column,
                         strain ? strain_names() : angle_names()),
      strain ? "strain" : "deflection angle", strain ? strain_names() : angle_names(),
      o.angle_column, defaults.angle_column);
  const auto ri = require(
      find_vendor_column(alts, o.torque_column, defaults.torque_column,
                         strain ? stress_names() : torque_names()),
      strain ? "stress" : "torque", strain ? stress_names() : torque_names(), o.torque_column,
      defaults.torque_column);
  {
    std::vector<UnitNeed> needs;
    if (ti) needs.push_back({UnitKind::kTime, shown[*ti], !unit_at(*ti).empty()});
    needs.push_back({drive_kind(o.quantity), shown[di],
                     !unit_at(di).empty() || drive_kind(o.quantity) == UnitKind::kStrain});
    needs.push_back({response_kind(o.quantity), shown[ri], !unit_at(ri).empty()});
    require_units(o, needs, where);
  }
  if (ti) vc.time = make(*ti, UnitKind::kTime);
  vc.drive = make(di, drive_kind(o.quantity));
  vc.response = make(ri, response_kind(o.quantity));
  return vc;
}

/// Records, once, that the log has no time column.
void note_no_time(OscillationLog& log) {
  if (core::metadata_value(log.parameters, "time_column").empty())
    log.parameters.emplace_back("time_column", "none (angle-sampled log)");
}

void no_interval_column(const LogReadOptions& o, const char* format) {
  if (!o.interval_column.empty())
    throw ConfigError(fmt::format("interval_column \"{}\" applies to generic CSV/TSV logs "
                                  "only; a {} export has its own segments",
                                  o.interval_column, format));
}

// ---- Anton Paar RheoCompass -------------------------------------------------------

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
    std::size_t first = 0;
    while (first < cells.size() && cells[first].empty()) ++first;
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
      std::size_t f = 0;
      while (f < row.size() && row[f].empty()) ++f;
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

// ---- TA Instruments TRIOS ---------------------------------------------------------

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

bool is_section_header(std::string_view line) {
  line = trim(line);
  return line.size() >= 2 && line.front() == '[' && line.back() == ']' &&
         line.find('\t') == std::string_view::npos;
}

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
                CsvWriter::format_number(trios_constant(cells, true, src, lines[i].number)));
          if (f == "strain constant")
            log.parameters.emplace_back(
                "strain_constant_per_rad",
                CsvWriter::format_number(trios_constant(cells, false, src, lines[i].number)));
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

// ---- RepTate .laos ----------------------------------------------------------------

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

// ---- Generic CSV/TSV --------------------------------------------------------------

/// "torque_N_m" -> ("torque", "N_m"); no '_' -> (name, "").
std::pair<std::string, std::string> split_suffix(std::string_view name) {
  const std::size_t p = name.find('_');
  if (p == std::string_view::npos) return {std::string(name), ""};
  return {std::string(name.substr(0, p)), std::string(name.substr(p + 1))};
}

struct GenericMatch {
  std::size_t index;
  std::string unit;  ///< from the bracket or the suffix
  bool has_unit;
};

/// Finds the column for an option name: exact header, header without its bracketed
/// unit, or (same word before '_' or the bracket) a header whose unit is of `kind`.
std::optional<GenericMatch> match_generic(const CsvTable& t, const std::string& option,
                                          UnitKind kind) {
  // 1. Exact.
  for (std::size_t k = 0; k < t.columns.size(); ++k)
    if (t.columns[k] == option) {
      auto [n, u] = split_bracketed_unit(t.columns[k]);
      if (!u.empty() && n != t.columns[k]) return GenericMatch{k, u, true};
      auto [stem, suffix] = split_suffix(t.columns[k]);
      return GenericMatch{k, suffix, !suffix.empty()};
    }
  // 2. Without the bracketed unit.
  for (std::size_t k = 0; k < t.columns.size(); ++k) {
    auto [n, u] = split_bracketed_unit(t.columns[k]);
    if (n != t.columns[k] && n == option) return GenericMatch{k, u, true};
  }
  // 3. Same word, other unit: "torque_N_m" finds "torque_mN_m" and "Torque [mN·m]".
  const std::string stem = fold(split_suffix(option).first);
  std::optional<GenericMatch> found;
  for (std::size_t k = 0; k < t.columns.size(); ++k) {
    auto [n, u] = split_bracketed_unit(t.columns[k]);
    std::optional<GenericMatch> m;
    if (n != t.columns[k]) {
      if (fold(n) == stem) m = GenericMatch{k, u, true};
    } else {
      auto [s, suffix] = split_suffix(t.columns[k]);
      if (fold(s) == stem && suffix.empty()) m = GenericMatch{k, "", false};
      if (fold(s) == stem && find_unit_scale(suffix, kind)) m = GenericMatch{k, suffix, true};
    }
    if (!m) continue;
    if (found)
      throw InputError(fmt::format("{}:{}: columns \"{}\" and \"{}\" both match \"{}\"; name "
                                   "the one to use",
                                   t.source, t.header_line, t.columns[found->index],
                                   t.columns[k], option));
    found = m;
  }
  return found;
}

void read_generic(std::string_view text, const LogReadOptions& o, OscillationLog& log) {
  const CsvTable t = parse_csv(text, log.source);
  log.parameters = t.metadata;
  const LogReadOptions defaults;
  const bool strain = o.quantity == LogQuantity::kStrainStress;
  // In strain/stress mode the default names are strain and stress_Pa.
  const std::string drive_option =
      strain && o.angle_column == defaults.angle_column ? "strain" : o.angle_column;
  const std::string response_option =
      strain && o.torque_column == defaults.torque_column ? "stress_Pa" : o.torque_column;

  auto missing = [&](const std::string& what, const std::string& option) {
    std::string have;
    for (const auto& c : t.columns) have += (have.empty() ? "\"" : ", \"") + c + "\"";
    return InputError(fmt::format("{}:{}: missing {} column \"{}\"; the header has: {}",
                                  t.source, t.header_line, what, option, have));
  };
  std::optional<GenericMatch> tm;
  if (!o.time_column.empty()) {
    tm = match_generic(t, o.time_column, UnitKind::kTime);
    if (!tm && o.time_column != defaults.time_column) throw missing("time", o.time_column);
  }
  const auto dm = match_generic(t, drive_option, drive_kind(o.quantity));
  if (!dm) throw missing(strain ? "strain" : "angle", drive_option);
  const auto rm = match_generic(t, response_option, response_kind(o.quantity));
  if (!rm) throw missing(strain ? "stress" : "torque", response_option);
  std::optional<std::size_t> interval;
  if (!o.interval_column.empty()) interval = t.column_index(o.interval_column);

  // An optional units row: the first row, with no number in the columns used.
  std::size_t first_row = 0;
  std::array<std::optional<std::string>, 3> row_units;
  if (t.num_rows() > 0) {
    const auto& r = t.rows[0];
    const std::array<std::optional<GenericMatch>, 3> ms{tm, dm, rm};
    bool units_row = true;
    for (const auto& m : ms)
      if (m && is_number(r[m->index])) units_row = false;
    if (units_row) {
      bool any = false;
      for (std::size_t k = 0; k < 3; ++k)
        if (ms[k] && !trim(r[ms[k]->index]).empty()) {
          row_units[k] = std::string(trim(r[ms[k]->index]));
          any = true;
        }
      if (any) first_row = 1;
    }
  }
  const std::string where = fmt::format("{}:{}", t.source, t.header_line);
  auto make = [&](const GenericMatch& m, UnitKind kind, const std::optional<std::string>& ru) {
    Column c;
    c.index = m.index;
    c.name = t.columns[m.index];
    if (ru) {
      c.scale = column_scale(o, kind, *ru, true,
                             fmt::format("{}:{}", t.source, t.row_lines[0]), c.name);
    } else {
      c.scale = column_scale(o, kind, m.unit, m.has_unit || kind == UnitKind::kStrain, where,
                             c.name);
    }
    return c;
  };
  {
    std::vector<UnitNeed> needs;
    if (tm) needs.push_back({UnitKind::kTime, t.columns[tm->index], row_units[0].has_value() || tm->has_unit});
    needs.push_back({drive_kind(o.quantity), t.columns[dm->index],
                     row_units[1].has_value() || dm->has_unit || drive_kind(o.quantity) == UnitKind::kStrain});
    needs.push_back({response_kind(o.quantity), t.columns[rm->index], row_units[2].has_value() || rm->has_unit});
    require_units(o, needs, where);
  }
  std::optional<Column> time;
  if (tm) time = make(*tm, UnitKind::kTime, row_units[0]);
  const Column drive = make(*dm, drive_kind(o.quantity), row_units[1]);
  const Column response = make(*rm, response_kind(o.quantity), row_units[2]);
  if (!time) note_no_time(log);

  std::vector<std::string_view> cells;
  for (std::size_t r = first_row; r < t.num_rows(); ++r) {
    const std::string label = interval ? std::string(trim(t.rows[r][*interval])) : "1";
    if (log.segments.empty() || log.segments.back().label != label) {
      if (interval && label.empty())
        throw InputError(fmt::format("{}:{}: column \"{}\": missing value (empty cell); "
                                     "expected an interval label",
                                     t.source, t.row_lines[r], o.interval_column));
      log.segments.emplace_back();
      log.segments.back().label = label;
    }
    cells.assign(t.rows[r].begin(), t.rows[r].end());
    append_sample(log.segments.back(), cells, time, drive, response, t.decimal_comma, t.source,
                  t.row_lines[r]);
  }
  if (time)
    for (const auto& s : log.segments) check_time(s, t.source, time->name);
}

// ---- Detection ----------------------------------------------------------------------

bool has_utf16_bom(const std::string& bytes) {
  return bytes.size() >= 2 && ((static_cast<unsigned char>(bytes[0]) == 0xFF &&
                                static_cast<unsigned char>(bytes[1]) == 0xFE) ||
                               (static_cast<unsigned char>(bytes[0]) == 0xFE &&
                                static_cast<unsigned char>(bytes[1]) == 0xFF));
}

/// First line like "omega=3.0;gamma=1.0;".
bool looks_like_reptate_header(std::string_view line) {
  line = trim(line);
  const std::size_t eq = line.find('=');
  const std::size_t semi = line.find(';');
  if (eq == std::string_view::npos || semi == std::string_view::npos || eq == 0 || eq > semi)
    return false;
  for (std::size_t k = 0; k < eq; ++k) {
    const char c = line[k];
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_')) return false;
  }
  return line.find('\t') == std::string_view::npos && line.find(',') == std::string_view::npos;
}

}  // namespace

// ---- Public -----------------------------------------------------------------------

const char* log_format_name(LogFormat f) {
  switch (f) {
    case LogFormat::kAuto: return "auto";
    case LogFormat::kCsv: return "csv";
    case LogFormat::kAntonPaar: return "anton-paar";
    case LogFormat::kTrios: return "trios";
    case LogFormat::kRepTate: return "reptate";
  }
  return "?";
}

LogFormat log_format_from_name(const std::string& name) {
  for (LogFormat f : {LogFormat::kAuto, LogFormat::kCsv, LogFormat::kAntonPaar, LogFormat::kTrios,
                      LogFormat::kRepTate})
    if (name == log_format_name(f)) return f;
  throw ConfigError(fmt::format("unknown log format \"{}\"; expected one of: auto, csv, "
                                "anton-paar, trios, reptate",
                                name));
}

std::string decode_text(const std::string& bytes, const std::string& source) {
  const auto* b = reinterpret_cast<const unsigned char*>(bytes.data());
  const std::size_t n = bytes.size();
  bool utf16 = false, big_endian = false;
  std::size_t start = 0;
  if (n >= 2 && b[0] == 0xFF && b[1] == 0xFE) {
    utf16 = true;
    start = 2;
  } else if (n >= 2 && b[0] == 0xFE && b[1] == 0xFF) {
    utf16 = big_endian = true;
    start = 2;
  } else if (n >= 4 && b[0] != 0 && b[1] == 0 && b[2] != 0 && b[3] == 0) {
    utf16 = true;  // UTF-16 LE without a BOM: ASCII text with zero high bytes
  }
  if (utf16) {
    if ((n - start) % 2 != 0)
      throw InputError(fmt::format("{}: invalid UTF-16 text: odd number of bytes ({}); expected "
                                   "2 bytes per code unit",
                                   source, n));
    std::string out;
    out.reserve(n);
    auto unit = [&](std::size_t k) -> std::uint32_t {
      return big_endian ? (std::uint32_t{b[k]} << 8) | b[k + 1]
                        : (std::uint32_t{b[k + 1]} << 8) | b[k];
    };
    for (std::size_t k = start; k < n; k += 2) {
      std::uint32_t cp = unit(k);
      if (cp >= 0xD800 && cp <= 0xDBFF) {
        if (k + 2 >= n || unit(k + 2) < 0xDC00 || unit(k + 2) > 0xDFFF)
          throw InputError(fmt::format("{}: invalid UTF-16 text at byte {}: a high surrogate "
                                       "(0x{:04X}) not followed by a low surrogate",
                                       source, k, cp));
        cp = 0x10000 + ((cp - 0xD800) << 10) + (unit(k + 2) - 0xDC00);
        k += 2;
      } else if (cp >= 0xDC00 && cp <= 0xDFFF) {
        throw InputError(fmt::format("{}: invalid UTF-16 text at byte {}: a lone low surrogate "
                                     "(0x{:04X})",
                                     source, k, cp));
      }
      if (cp < 0x80) {
        out += static_cast<char>(cp);
      } else if (cp < 0x800) {
        out += static_cast<char>(0xC0 | (cp >> 6));
        out += static_cast<char>(0x80 | (cp & 0x3F));
      } else if (cp < 0x10000) {
        out += static_cast<char>(0xE0 | (cp >> 12));
        out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
        out += static_cast<char>(0x80 | (cp & 0x3F));
      } else {
        out += static_cast<char>(0xF0 | (cp >> 18));
        out += static_cast<char>(0x80 | ((cp >> 12) & 0x3F));
        out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
        out += static_cast<char>(0x80 | (cp & 0x3F));
      }
    }
    return out;
  }
  if (n >= 3 && b[0] == 0xEF && b[1] == 0xBB && b[2] == 0xBF) start = 3;
  // Valid UTF-8 is kept; anything else is read as Latin-1 (ISO 8859-1: older
  // exports write "µ" and "°" as the single bytes 0xB5 and 0xB0).
  bool valid = true;
  for (std::size_t k = start; k < n && valid;) {
    const unsigned char c = b[k];
    std::size_t len = c < 0x80 ? 1 : (c >> 5) == 6 ? 2 : (c >> 4) == 14 ? 3 : (c >> 3) == 30 ? 4 : 0;
    if (len == 0 || k + len > n) {
      valid = false;
      break;
    }
    for (std::size_t j = 1; j < len; ++j) valid &= (b[k + j] & 0xC0) == 0x80;
    k += len;
  }
  if (valid) return bytes.substr(start);
  std::string out;
  for (std::size_t k = start; k < n; ++k) {
    const unsigned char c = b[k];
    if (c < 0x80) {
      out += static_cast<char>(c);
    } else {
      out += static_cast<char>(0xC0 | (c >> 6));
      out += static_cast<char>(0x80 | (c & 0x3F));
    }
  }
  return out;
}

OscillationLog read_oscillation_log(const std::filesystem::path& path,
                                    const LogReadOptions& options) {
  const std::string bytes = read_file_bytes(path, "log file");
  OscillationLog log;
  log.source = path.string();
  log.quantity = options.quantity;
  const std::string text = decode_text(bytes, log.source);

  LogFormat format = options.format;
  if (format == LogFormat::kAuto) {
    const auto lines = split_lines(text);
    bool interval_marker = false, section = false, tab_pairs = false;
    for (const auto& l : lines) {
      const auto cells = split_cells(l.text, '\t');
      std::size_t f = 0;
      while (f < cells.size() && cells[f].empty()) ++f;
      if (f < cells.size() && is_interval_marker(cells[f])) interval_marker = true;
      if (is_section_header(l.text)) section = true;
      if (cells.size() >= 2 && !cells[0].empty() && !is_number(cells[0])) tab_pairs = true;
    }
    std::string_view first_line;
    for (const auto& l : lines)
      if (!trim(l.text).empty()) {
        first_line = l.text;
        break;
      }
    if (interval_marker) {
      format = LogFormat::kAntonPaar;
    } else if (section && tab_pairs) {
      format = LogFormat::kTrios;
    } else if (has_utf16_bom(bytes)) {
      format = LogFormat::kAntonPaar;
    } else if (path.extension() == ".laos" || looks_like_reptate_header(first_line)) {
      format = LogFormat::kRepTate;
    } else {
      format = LogFormat::kCsv;
    }
  }
  log.format = format;
  switch (format) {
    case LogFormat::kAntonPaar: read_anton_paar(text, options, log); break;
    case LogFormat::kTrios: read_trios(text, options, log); break;
    case LogFormat::kRepTate: read_reptate(text, options, log); break;
    case LogFormat::kCsv:
    case LogFormat::kAuto: read_generic(text, options, log); break;
  }
  finish(log);
  return log;
}

}  // namespace shearzone::io
