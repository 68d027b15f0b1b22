// Shared pieces of the rheometer log readers (declared in log_common.hpp): text
// helpers, sample columns, unit resolution, localised column names.
#include "log_common.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/core/metadata.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/io/file.hpp"

namespace shearzone::io::log_detail {
namespace {

bool parse_plain_number(std::string_view s, double& v) { return parse_number(s, true, v); }

constexpr std::array<std::string_view, 3> kIntervalMarkers{
    "interval data:", "intervalldaten:", "donn\xC3\xA9" "es d'intervalle:"};

}  // namespace

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

std::size_t first_nonempty(const std::vector<std::string_view>& cells) {
  std::size_t f = 0;
  while (f < cells.size() && cells[f].empty()) ++f;
  return f;
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


/// Fills the convenience lookups from `parameters`.
void finish(OscillationLog& log, bool allow_empty) {
  auto lookup = [&](const char* key, double& out) {
    const std::string v = core::metadata_value(log.parameters, key);
    double x = 0;
    if (!v.empty() && parse_plain_number(v, x)) out = x;
  };
  lookup("omega_rad_per_s", log.omega_rad_per_s);
  lookup("stress_constant_Pa_per_N_m", log.stress_constant_Pa_per_N_m);
  lookup("strain_constant_per_rad", log.strain_constant_per_rad);
  if (log.segments.empty() && !allow_empty)
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


bool is_table_header(const std::vector<std::string_view>& cells, std::size_t first) {
  if (first >= cells.size()) return false;
  if (is_interval_marker(cells[first])) return true;
  if (cells[first].empty() || cells[first].back() != ':') return false;
  std::size_t names = 0;
  for (std::size_t k = first + 1; k < cells.size(); ++k) {
    if (cells[k].empty()) continue;
    if (is_number(cells[k])) return false;
    ++names;
  }
  return names >= 3;
}

bool is_interval_marker(std::string_view first_cell) {
  const std::string f = fold(first_cell);
  for (auto m : kIntervalMarkers)
    if (f == m || f + ":" == m) return true;
  return false;
}

const std::vector<std::string>& time_names() {
  static const std::vector<std::string> v{
      "time", "zeit", "temps", "interval time", "intervallzeit", "temps d'intervalle",
      "temps de l'intervalle", "step time", "test time", "versuchszeit", "temps d'essai",
      "period time", "periodenzeit", "temps de p\xC3\xA9riode"};
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

double cell_or_unset(const std::vector<std::string_view>& cells, std::optional<std::size_t> col,
                     double scale) {
  double v = 0;
  if (!col || *col >= cells.size() || cells[*col].empty() || !parse_number(cells[*col], true, v) ||
      !std::isfinite(v))
    return core::kUnset;
  return v * scale;
}

double instrument_value(const std::vector<std::string_view>& cells, std::optional<std::size_t> col, double scale,
                        bool positive, const char* what, const std::string& source, std::size_t line) {
  if (!col || *col >= cells.size() || trim(cells[*col]).empty()) return core::kUnset;
  const std::string_view cell = trim(cells[*col]);
  double v = 0;
  if (!parse_number(cell, true, v) || !std::isfinite(v))
    throw InputError(fmt::format("{}:{}: the instrument's {}: \"{}\" is not a finite number", source, line, what,
                                 cell));
  if (positive && !(v > 0))
    throw InputError(fmt::format("{}:{}: the instrument's {}: {}; expected > 0", source, line, what, cell));
  return v * scale;
}

double unit_scale_or_unset(const std::string& unit, UnitKind kind) {
  return find_unit_scale(unit, kind).value_or(core::kUnset);
}

void refuse_without_waveform(const OscillationLog& log, std::size_t blocks, const char* block_word,
                             const std::string& first_error, const std::string& hint) {
  // One block: its own message (it names the columns looked for and those found).
  if (blocks == 1 && log.skipped.size() == 1 && !first_error.empty()) throw InputError(first_error);
  throw InputError(fmt::format(
      "{}: no raw waveform in {} {}{} ({}{}); shearzone laos needs the drive and response "
      "samples{}",
      log.source, blocks, block_word, blocks == 1 ? "" : "s",
      log.skipped.empty() ? std::string("none listed") : excerpt(log.skipped.front(), 300),
      log.skipped.size() > 1 ? fmt::format("; {} more", log.skipped.size() - 1) : "", hint));
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


bool is_section_header(std::string_view line) {
  line = trim(line);
  return line.size() >= 2 && line.front() == '[' && line.back() == ']' &&
         line.find('\t') == std::string_view::npos;
}

}  // namespace shearzone::io::log_detail
