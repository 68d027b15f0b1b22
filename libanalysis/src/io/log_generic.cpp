// Generic CSV/TSV logs: columns found by name with units in brackets or name suffixes.
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

}  // namespace

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
    // A table of results per point (storage and loss moduli): say so.
    std::vector<std::vector<std::string>> alts;
    for (const auto& c : t.columns) alts.push_back({split_bracketed_unit(c).first});
    if (find_localised(alts, {"storage modulus", "loss modulus", "speichermodul", "verlustmodul",
                              "module de stockage", "module de perte"}))
      return InputError(fmt::format("{}:{}: results per point (storage and loss moduli), no raw "
                                    "waveform: no {} column \"{}\"; the header has: {}",
                                    t.source, t.header_line, what, option, excerpt(have, 300)));
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

}  // namespace shearzone::io::log_detail
