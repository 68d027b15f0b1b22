// Malvern Kinexus rSpace CSV exports: ';' separated, decimal commas, headers
// "Name(unit)", one row per sample with the action (step) name in the first column.
//
// Seen in a real export (rSpace, Kinexus): the raw waveform rows of an oscillation
// action fill time, torque and angular displacement only; after them the same action
// appends summary rows (frequency, G', G'', G* every few seconds) whose action time
// restarts. Times are printed with 4 significant digits, so above 100 s consecutive
// samples tie. Per action: raw rows -> one segment (label: the action name); an action
// without summary frequency (pre-shear, rest, flow curve) or without raw rows (an
// amplitude table) is skipped and listed.
#include "log_common.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <string_view>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/io/file.hpp"

namespace shearzone::io::log_detail {
namespace {

struct Action {
  std::string name;
  std::size_t first_line = 0;
  std::vector<std::vector<std::string_view>> raw, summary;
  std::vector<std::size_t> raw_lines;
};

std::optional<std::size_t> find_column(const std::vector<std::string>& names,
                                       std::initializer_list<std::string_view> candidates) {
  for (auto c : candidates)
    for (std::size_t k = 0; k < names.size(); ++k)
      if (fold(names[k]) == c) return k;
  return std::nullopt;
}

bool filled(const std::vector<std::string_view>& row, std::optional<std::size_t> k) {
  return k && *k < row.size() && !row[*k].empty();
}

}  // namespace

bool looks_like_malvern(std::string_view first_line) {
  const auto cells = split_cells(first_line, ';');
  return cells.size() >= 3 && fold(cells[0]) == "action name";
}

void read_malvern(std::string_view text, const LogReadOptions& o, OscillationLog& log) {
  no_interval_column(o, "Malvern rSpace");
  const std::string& src = log.source;
  const auto lines = split_lines(text);
  std::size_t i = 0;
  while (i < lines.size() && trim(lines[i].text).empty()) ++i;
  if (i == lines.size()) return;
  const std::size_t header_line = lines[i].number;
  std::vector<std::string> names, units;
  for (auto c : split_cells(lines[i].text, ';')) {
    auto [n, u] = split_bracketed_unit(c);
    names.push_back(n);
    units.push_back(u);
  }
  ++i;
  const std::string where = fmt::format("{}:{}", src, header_line);
  // The columns: time of the action, torque, angle (the raw samples); frequency and the
  // moduli (the summary rows).
  const auto tcol = find_column(names, {"time (action)", "time"});
  const auto qcol = find_column(names, {"torque"});
  const auto acol = find_column(names, {"angular displacement", "displacement"});
  const auto fcol = find_column(names, {"frequency"});
  const auto gpcol = find_column(names, {"shear modulus (elastic component)", "elastic modulus"});
  const auto gppcol = find_column(names, {"shear modulus (viscous component)", "viscous modulus"});
  if (!qcol || !acol)
    throw InputError(fmt::format("{}: no {} column (looked for \"Torque\", \"Angular "
                                 "displacement\"); the header has: {}",
                                 where, !qcol ? "torque" : "angular displacement",
                                 list_names(names)));
  if (o.quantity != LogQuantity::kAngleTorque)
    throw ConfigError(fmt::format("{}: a Malvern export is read as angle and torque (its raw "
                                  "samples); --strain/--stress do not apply",
                                  where));
  Column time, drive, response;
  drive = {*acol, names[*acol],
           column_scale(o, UnitKind::kAngle, units[*acol], !units[*acol].empty(), where, names[*acol])};
  response = {*qcol, names[*qcol],
              column_scale(o, UnitKind::kTorque, units[*qcol], !units[*qcol].empty(), where, names[*qcol])};
  if (tcol)
    time = {*tcol, names[*tcol],
            column_scale(o, UnitKind::kTime, units[*tcol], !units[*tcol].empty(), where, names[*tcol])};
  const double fscale = fcol && fold(units[*fcol]) == "hz" ? 1.0 : core::kUnset;
  const double gpscale = gpcol ? unit_scale_or_unset(units[*gpcol], UnitKind::kStress) : core::kUnset;
  const double gppscale = gppcol ? unit_scale_or_unset(units[*gppcol], UnitKind::kStress) : core::kUnset;

  // Rows grouped into consecutive runs of one action.
  std::vector<Action> actions;
  for (; i < lines.size(); ++i) {
    if (trim(lines[i].text).empty()) continue;
    auto row = split_cells(lines[i].text, ';');
    const std::string name(row[0]);
    if (actions.empty() || actions.back().name != name) {
      actions.push_back({});
      actions.back().name = name;
      actions.back().first_line = lines[i].number;
    }
    Action& a = actions.back();
    if (filled(row, fcol)) {
      a.summary.push_back(std::move(row));
    } else if (filled(row, qcol) && filled(row, acol)) {
      a.raw.push_back(std::move(row));
      a.raw_lines.push_back(lines[i].number);
    }
  }

  for (const Action& a : actions) {
    const std::string at = fmt::format("{} (line {})", a.name, a.first_line);
    // Oscillatory: the instrument reports a frequency for it.
    double f_Hz = core::kUnset;
    for (const auto& r : a.summary) {
      const double f = cell_or_unset(r, fcol, fscale);
      if (f > 0) f_Hz = f;
    }
    if (!(f_Hz > 0)) {
      log.skipped.push_back(at + ": not an oscillation (no frequency reported)");
      continue;
    }
    if (a.raw.size() < 4) {
      log.skipped.push_back(fmt::format("{}: no raw waveform ({} summary rows of frequency, G', "
                                        "G'' only)",
                                        at, a.summary.size()));
      continue;
    }
    LogSegment seg;
    seg.label = a.name;
    seg.instrument_frequency_Hz = f_Hz;
    if (!a.summary.empty()) {  // the last summary row: the end of the action
      seg.instrument_G_prime_Pa = cell_or_unset(a.summary.back(), gpcol, gpscale);
      seg.instrument_G_dprime_Pa = cell_or_unset(a.summary.back(), gppcol, gppscale);
    }
    const std::optional<Column> tc = tcol ? std::optional<Column>(time) : std::nullopt;
    for (std::size_t k = 0; k < a.raw.size(); ++k)
      append_sample(seg, a.raw[k], tc, drive, response, true, src, a.raw_lines[k]);
    if (!seg.time_s.empty()) {
      // Printed times tie once 4 significant digits no longer resolve the sample
      // interval: rebuild them from the interval of the first samples when every printed
      // time agrees with the rebuilt one to its printed precision.
      bool ties = false;
      for (std::size_t k = 1; k < seg.time_s.size(); ++k) ties |= !(seg.time_s[k] > seg.time_s[k - 1]);
      if (ties) {
        // Weighted least squares t_k ≈ t0 + k dt, each printed time weighted by the
        // inverse square of its printed resolution (4 significant digits).
        double sw = 0, sk = 0, st = 0, skk = 0, skt = 0;
        for (std::size_t k = 0; k < seg.time_s.size(); ++k) {
          const double kk = static_cast<double>(k), t = seg.time_s[k];
          const double res = t != 0 ? std::pow(10.0, std::floor(std::log10(std::abs(t))) - 3) : 1e-4;
          const double w = 1.0 / (res * res);
          sw += w, sk += w * kk, st += w * t, skk += w * kk * kk, skt += w * kk * t;
        }
        const double dt = (sw * skt - sk * st) / (sw * skk - sk * sk);
        const double t0 = (st - dt * sk) / sw;
        constexpr double kPrinted = 5e-4;  // half a unit of the 4th significant digit, relative
        bool consistent = dt > 0;
        std::size_t bad = 0;
        for (std::size_t k = 0; k < seg.time_s.size() && consistent; ++k) {
          const double t = t0 + dt * static_cast<double>(k);
          if (std::abs(t - seg.time_s[k]) > kPrinted * std::abs(seg.time_s[k]) + 0.01 * dt) {
            consistent = false;
            bad = k;
          }
        }
        if (!consistent)
          throw InputError(fmt::format(
              "{}:{}: action \"{}\": time {} s repeats or goes back and the samples are not "
              "evenly spaced (expected {} s at a sample interval of {:.6g} s); expected "
              "increasing times",
              src, seg.line[bad], a.name, seg.time_s[bad],
              t0 + dt * static_cast<double>(bad), dt));
        for (std::size_t k = 0; k < seg.time_s.size(); ++k) seg.time_s[k] = t0 + dt * static_cast<double>(k);
        log.parameters.emplace_back(
            "time_rebuilt",
            fmt::format("{}: printed times tie; rebuilt as t0 + k dt, t0 = {:.6g} s, dt = {:.6g} s "
                        "(least squares over the printed times, weighted by their resolution)",
                        a.name, t0, dt));
      }
      check_time(seg, src, time.name);
    } else {
      note_no_time(log);
    }
    log.segments.push_back(std::move(seg));
  }
  if (log.segments.empty() && !o.inspect)
    throw InputError(fmt::format(
        "{}: no oscillation action with a raw waveform ({} action{}: {}); shearzone laos needs "
        "the raw torque and angle samples (rSpace: export the raw data of the oscillation "
        "actions)",
        src, actions.size(), actions.size() == 1 ? "" : "s",
        log.skipped.empty() ? "none" : excerpt(log.skipped.front(), 200)));
}

}  // namespace shearzone::io::log_detail
