// Anton Paar RheoCompass exports, in any user-interface language.
//
// The block structure is recognised, not the words: a table starts at a line whose first
// cell ends with ':' and names at least three columns (or at the known "Interval data:"
// markers); further name rows and a row of bracketed units follow; data rows run until
// a line whose first cell is text. Name/value lines in between ("Result:", "Interval and
// data points: 3 51") label the tables. Two layouts of a table:
//  - waveform points: a point row (with its number in the first column) followed by
//    continuation rows that fill only the waveform columns; each point is one segment,
//    flagged closed_cycle when its last sample equals its first (one stored period);
//  - one sample per row (time, drive, response on every row): one segment per table.
// A table that holds neither (a summary of G', G'' per point, a flow curve) is skipped
// and listed in OscillationLog::skipped.
#include "log_common.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <set>
#include <string_view>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/core/metadata.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/io/file.hpp"

namespace shearzone::io::log_detail {
namespace {

struct Row {
  std::size_t line;
  std::vector<std::string_view> cells;
};

/// One table: names per column (with alternatives), units, data rows.
struct Table {
  std::size_t marker_line = 0, header_line = 0;
  std::vector<std::vector<std::string>> alts;
  std::vector<std::string> units;
  std::vector<Row> rows;
  std::size_t point_column = 0;  ///< the first named column (the point number)
};

bool key_is(std::string_view key, std::initializer_list<std::string_view> names) {
  std::string k = fold(key);
  if (!k.empty() && k.back() == ':') k.pop_back();
  return std::any_of(names.begin(), names.end(), [&](std::string_view n) { return k == n; });
}

/// "Shear Strain (for sinusoidal strain)" -> "Shear Strain"; "" when nothing to strip.
std::string strip_parenthesis(const std::string& name) {
  if (name.empty() || name.back() != ')') return "";
  const std::size_t p = name.rfind('(');
  if (p == std::string::npos || p == 0) return "";
  return std::string(trim(std::string_view(name).substr(0, p)));
}

/// Column of a point-level quantity among the columns not in `skip`.
std::optional<std::size_t> find_point_column(const Table& t, const std::set<std::size_t>& skip,
                                             std::initializer_list<std::string_view> names) {
  for (std::size_t i = 0; i < t.alts.size(); ++i) {
    if (skip.count(i) != 0) continue;
    for (const auto& a : t.alts[i])
      if (key_is(a, names)) return i;
  }
  return std::nullopt;
}

bool has_cell(const Row& r, std::size_t k) { return k < r.cells.size() && !r.cells[k].empty(); }

/// Reads the names, further name rows and units of a table starting at lines[i] (the
/// marker line); leaves i at the first data row.
Table read_header(const std::vector<TextLine>& lines, std::size_t& i,
                  const std::vector<std::string_view>& cells, std::size_t first,
                  const std::string& src) {
  Table t;
  t.marker_line = lines[i].number;
  std::vector<std::string_view> name_cells(cells.begin(), cells.end());
  name_cells[first] = "";
  ++i;
  if (all_empty(name_cells)) {
    while (i < lines.size() && trim(lines[i].text).empty()) ++i;
    if (i == lines.size())
      throw InputError(fmt::format("{}:{}: \"Interval data:\" line without column names", src,
                                   t.marker_line));
    name_cells = split_cells(lines[i].text, '\t');
    ++i;
  }
  t.header_line = i > 0 ? lines[i - 1].number : t.marker_line;
  for (auto c : name_cells) {
    auto [n, u] = split_bracketed_unit(c);
    t.alts.push_back({n});
    t.units.push_back(u);
  }
  t.point_column = first_nonempty(name_cells);
  // Further name rows ("Waveform"), then the units row.
  while (i < lines.size()) {
    const auto row = split_cells(lines[i].text, '\t');
    if (all_empty(row)) {
      ++i;
      continue;
    }
    if (std::any_of(row.begin(), row.end(), is_number)) break;
    bool units_row = true;
    for (auto c : row) units_row &= c.empty() || is_bracketed(c);
    if (t.alts.size() < row.size()) {
      t.alts.resize(row.size());
      t.units.resize(row.size());
    }
    for (std::size_t k = 0; k < row.size(); ++k) {
      if (row[k].empty()) continue;
      if (units_row) {
        t.units[k] = std::string(row[k].substr(1, row[k].size() - 2));
      } else {
        // A second name row: the column is known by the joined name and either part.
        const std::string joined = t.alts[k].empty() || t.alts[k].front().empty()
                                       ? std::string(row[k])
                                       : t.alts[k].front() + " " + std::string(row[k]);
        t.alts[k].insert(t.alts[k].begin(), joined);
        t.alts[k].emplace_back(row[k]);
      }
    }
    t.header_line = lines[i].number;
    ++i;
    if (units_row) break;
  }
  // Each name also without a trailing parenthesis ("Shear Strain (for sinusoidal strain)").
  for (auto& a : t.alts) {
    const std::size_t n = a.size();
    for (std::size_t k = 0; k < n; ++k)
      if (auto s = strip_parenthesis(a[k]); !s.empty()) a.push_back(s);
  }
  // Data rows, until a first cell that is text (a new table or a name/value line).
  while (i < lines.size()) {
    auto row = split_cells(lines[i].text, '\t');
    const std::size_t f = first_nonempty(row);
    if (f == row.size()) {
      ++i;
      continue;
    }
    if (f == 0 && !is_number(row[0])) break;
    t.rows.push_back({lines[i].number, std::move(row)});
    ++i;
  }
  return t;
}

/// Drive/response/time columns among `alts`; with `auto_quantity` strain/stress when
/// angle/torque are absent. nullopt (and `why`) when the table has none.
std::optional<VendorColumns> resolve(const std::vector<std::vector<std::string>>& alts,
                                     const Table& t, const LogReadOptions& o,
                                     bool auto_quantity, const std::string& src,
                                     LogQuantity& quantity, std::string& why) {
  try {
    quantity = o.quantity;
    return resolve_vendor_columns(alts, t.units, o, src, t.header_line);
  } catch (const InputError& e) {
    why = e.what();
  }
  if (auto_quantity) {
    LogReadOptions s = o;
    s.quantity = LogQuantity::kStrainStress;
    try {
      quantity = LogQuantity::kStrainStress;
      return resolve_vendor_columns(alts, t.units, s, src, t.header_line);
    } catch (const InputError&) {
    }
  }
  return std::nullopt;
}

}  // namespace

void read_anton_paar(std::string_view text, const LogReadOptions& o, OscillationLog& log) {
  no_interval_column(o, "RheoCompass");
  const auto lines = split_lines(text);
  const std::string& src = log.source;
  const LogReadOptions defaults;
  // No quantity chosen by name: the waveform columns decide (angle/torque, else strain/stress).
  const bool auto_quantity = o.quantity == LogQuantity::kAngleTorque &&
                             o.angle_column == defaults.angle_column &&
                             o.torque_column == defaults.torque_column;
  bool quantity_fixed = false;
  std::string result_name, interval_number, first_error;  // first_error: as the reader said it
  std::size_t tables = 0;

  auto add_parameter = [&](const std::vector<std::string_view>& cells) {
    std::string key, value;
    std::vector<std::string_view> values;
    for (auto c : cells) {
      if (c.empty()) continue;
      if (key.empty()) {
        key = std::string(c);
      } else {
        if (!value.empty()) value += ' ';
        value += c;
        values.push_back(c);
      }
    }
    if (!key.empty() && key.back() == ':') key.pop_back();
    if (key.empty()) return;
    log.parameters.emplace_back(std::string(trim(key)), value);
    if (key_is(key, {"result", "ergebnis", "r\xC3\xA9sultat"})) {
      result_name = value;
      interval_number.clear();
    }
    if (key_is(key, {"interval and data points", "intervall und datenpunkte",
                     "intervalle et points de donn\xC3\xA9" "es"}) &&
        !values.empty())
      interval_number = std::string(values.front());
  };

  std::size_t i = 0;
  while (i < lines.size()) {
    const auto cells = split_cells(lines[i].text, '\t');
    const std::size_t first = first_nonempty(cells);
    if (first == cells.size()) {
      ++i;
      continue;
    }
    if (!is_table_header(cells, first)) {
      add_parameter(cells);
      ++i;
      continue;
    }
    const Table t = read_header(lines, i, cells, first, src);
    ++tables;
    std::string label = result_name;
    if (!interval_number.empty())
      label += (label.empty() ? "interval " : " / interval ") + interval_number;
    if (label.empty()) label = std::to_string(tables);
    auto skip = [&](const std::string& why, const std::string& error = {}) {
      log.skipped.push_back(fmt::format("{} (line {}): {}", label, t.marker_line, why));
      if (first_error.empty()) first_error = error;
    };
    if (t.rows.empty()) {
      // A table without data (a rest or pre-shear step): noted, not a segment.
      log.parameters.emplace_back("empty_interval",
                                  fmt::format("{} (line {}: no data rows)", label, t.marker_line));
      skip("no data rows");
      continue;
    }

    // Waveform columns: those filled on continuation rows (no point number).
    std::set<std::size_t> wave;
    for (const auto& r : t.rows)
      if (!has_cell(r, t.point_column))
        for (std::size_t k = 0; k < r.cells.size(); ++k)
          if (!r.cells[k].empty()) wave.insert(k);
    const bool points_layout = !wave.empty();
    auto alts = t.alts;
    if (points_layout)
      for (std::size_t k = 0; k < alts.size(); ++k)
        if (wave.count(k) == 0) alts[k].clear();
    LogQuantity q = o.quantity;
    std::string why;
    const auto vc = resolve(alts, t, o, auto_quantity && !quantity_fixed && points_layout, src, q, why);
    if (!vc) {
      std::vector<std::string> shown;
      for (std::size_t k = 0; k < t.alts.size(); ++k)
        if ((!points_layout || wave.count(k) != 0) && !t.alts[k].empty())
          shown.push_back(t.alts[k].front());
      skip(points_layout ? "waveform columns " + list_names(shown) + " hold no drive and response"
                         : "no raw waveform, one row per point (a summary or a flow curve) with "
                           "columns " + list_names(shown),
           why);
      continue;
    }
    if (quantity_fixed && q != log.quantity) {
      skip("its waveform is in other quantities than the file's first one");
      continue;
    }
    log.quantity = q;
    quantity_fixed = true;

    if (!points_layout) {
      LogSegment seg;
      seg.label = label;
      // A waveform table (drive and response found) with a cell that does not read as
      // a number (text, empty, overflowing, a thousands separator, a stray byte-order
      // mark) is damaged: refused with its line, never dropped; --inspect lists it.
      try {
        for (const auto& r : t.rows)
          append_sample(seg, r.cells, vc->time, vc->drive, vc->response, true, src, r.line);
      } catch (const InputError& e) {
        if (!o.inspect) throw;
        skip(std::string("unreadable samples: ") + e.what(), e.what());
        continue;
      }
      if (!vc->time) note_no_time(log);
      if (vc->time) check_time(seg, src, vc->time->name);
      log.segments.push_back(std::move(seg));
      continue;
    }

    // Point-level values the instrument reported (columns outside the waveform).
    const auto fcol = find_point_column(t, wave, {"frequency", "frequenz", "fr\xC3\xA9quence"});
    const auto wcol = find_point_column(t, wave, {"angular frequency", "kreisfrequenz",
                                                  "fr\xC3\xA9quence angulaire"});
    const auto gpcol = find_point_column(t, wave, {"storage modulus", "speichermodul",
                                                   "module de stockage"});
    const auto gppcol = find_point_column(t, wave, {"loss modulus", "verlustmodul", "module de perte"});
    const auto tqcol = find_point_column(t, wave, {"torque", "drehmoment", "couple"});
    auto unit_of = [&](std::optional<std::size_t> c) {
      return c && *c < t.units.size() ? t.units[*c] : std::string();
    };
    const double fscale = fold(unit_of(fcol)) == "hz" ? 1.0 : core::kUnset;
    const std::string wu = fold(unit_of(wcol));
    const double wscale = (wu == "rad/s" || wu == "1/s") ? 1.0 / (2 * std::numbers::pi) : core::kUnset;
    const double gpscale = unit_scale_or_unset(unit_of(gpcol), UnitKind::kStress);
    const double gppscale = unit_scale_or_unset(unit_of(gppcol), UnitKind::kStress);
    const double tqscale = unit_scale_or_unset(unit_of(tqcol), UnitKind::kTorque);

    std::size_t r = 0;
    while (r < t.rows.size()) {
      const std::size_t start = r;
      const Row& head = t.rows[r];
      std::size_t end = r + 1;
      while (end < t.rows.size() && !has_cell(t.rows[end], t.point_column)) ++end;
      LogSegment seg;
      seg.label = fmt::format("{} / point {}", label,
                              has_cell(head, t.point_column) ? std::string(head.cells[t.point_column])
                                                             : std::to_string(r + 1));
      // Range-checked: a frequency of 0 or below gave infinite or negative viscosities.
      seg.instrument_frequency_Hz = instrument_value(head.cells, fcol, fscale, true, "frequency", src, head.line);
      if (std::isnan(seg.instrument_frequency_Hz))
        seg.instrument_frequency_Hz =
            instrument_value(head.cells, wcol, wscale, true, "angular frequency", src, head.line);
      seg.instrument_G_prime_Pa = instrument_value(head.cells, gpcol, gpscale, false, "storage modulus", src, head.line);
      seg.instrument_G_dprime_Pa = instrument_value(head.cells, gppcol, gppscale, false, "loss modulus", src, head.line);
      seg.instrument_torque_N_m = instrument_value(head.cells, tqcol, tqscale, false, "torque", src, head.line);
      bool has_time = vc->time.has_value();
      std::size_t filled = 0, first_gap = 0;
      for (std::size_t k = r; k < end; ++k) {
        const Row& row = t.rows[k];
        if (!has_cell(row, vc->drive.index) || !has_cell(row, vc->response.index)) {
          if (!first_gap) first_gap = k + 1;
          continue;
        }
        ++filled;
        if (has_time && !has_cell(row, vc->time->index)) has_time = false;
      }
      const bool complete = filled == end - r;
      // Some rows of a point with their waveform and others without: a damaged point,
      // refused with the line of its first gap (a point without any is no waveform).
      if (!complete && filled > 0 && !o.inspect) {
        const Row& gap = t.rows[first_gap - 1];
        const Column& col = has_cell(gap, vc->drive.index) ? vc->response : vc->drive;
        throw InputError(fmt::format("{}:{}: column \"{}\": missing value (empty cell) in the waveform of {}; "
                                     "expected a number",
                                     src, gap.line, col.name, seg.label));
      }
      r = end;
      if (!complete) {
        log.skipped.push_back(fmt::format("{} (line {}): no waveform samples", seg.label, head.line));
        continue;
      }
      const std::optional<Column> time = has_time ? vc->time : std::nullopt;
      for (std::size_t k = start; k < end; ++k)
        append_sample(seg, t.rows[k].cells, time, vc->drive, vc->response, true, src, t.rows[k].line);
      const std::size_t n = seg.drive.size();
      const auto [xmin, xmax] = std::minmax_element(seg.drive.begin(), seg.drive.end());
      const auto [rmin, rmax] = std::minmax_element(seg.response.begin(), seg.response.end());
      constexpr double kClosure = 1e-6;  // relative to the range: equal as printed
      seg.closed_cycle = n >= 8 &&
                         std::abs(seg.drive.back() - seg.drive.front()) <= kClosure * (*xmax - *xmin) &&
                         std::abs(seg.response.back() - seg.response.front()) <= kClosure * (*rmax - *rmin);
      if (!seg.time_s.empty()) {
        if (seg.closed_cycle) {
          seg.time_s.clear();  // one period: the phase of sample k is 2 pi k/(n - 1)
        } else {
          check_time(seg, src, vc->time->name);
        }
      }
      if (!seg.closed_cycle && seg.time_s.empty()) note_no_time(log);
      log.segments.push_back(std::move(seg));
    }
  }
  // No table at all: finish() reports "no data rows".
  if (log.segments.empty() && !o.inspect && tables > 0)
    refuse_without_waveform(log, tables, "table", first_error,
                            " (RheoCompass: export the raw data / waveform columns)");
}

}  // namespace shearzone::io::log_detail
