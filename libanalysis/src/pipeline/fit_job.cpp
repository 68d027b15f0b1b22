#include "shearzone/pipeline/fit_job.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/io/atomic_output.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/io/grouped_table.hpp"

namespace shearzone::pipeline {
namespace {

using io::format_number_or_empty;

std::string model_name(FitModel m) { return m == FitModel::kErf ? "erf" : "power"; }

}  // namespace

std::filesystem::path sibling_output(const std::filesystem::path& output, const std::string& suffix) {
  auto p = output;
  p.replace_filename(output.stem().string() + suffix + output.extension().string());
  return p;
}

void FitJobOptions::validate() const {
  fit.validate();
  if (x_column.empty() || y_column.empty()) throw ConfigError("fit: --x and --y are required");
  if (output.empty()) throw ConfigError("fit: --output is required");
  if (!(group_rtol >= 0) || !std::isfinite(group_rtol))
    throw ConfigError(fmt::format("--group-rtol {}: must be >= 0", group_rtol));
  if (model != FitModel::kPower && !std::isnan(subtract_at))
    throw ConfigError("--subtract-at applies to power-law fits only");
  if (model != FitModel::kPower && space != fit::PowerSpace::kLinear)
    throw ConfigError("--space applies to power-law fits only");
  if (!std::isnan(subtract_at) && !std::isfinite(subtract_at))
    throw ConfigError("--subtract-at: must be a finite number");
}

namespace {

/// The parameters' names and units (from the x and y columns' unit suffixes).
struct ParameterNames {
  std::vector<std::string> names, units;
};
ParameterNames parameter_names(bool erf, const io::GroupedData& g) {
  ParameterNames pn;
  pn.names = erf ? std::vector<std::string>{"rc0", "rcinf", "phi_c", "W"} : std::vector<std::string>{"A", "k"};
  const std::string ux = g.x_unit, uy = g.y_unit;
  std::vector<std::string>& units = pn.units;
  if (erf) {
    units = {uy.empty() ? "as y" : uy, uy.empty() ? "as y" : uy, ux.empty() ? "as x" : ux,
             ux.empty() ? "as x" : ux};
  } else {
    units = {uy.empty() || ux.empty() ? "as y at x = 1" : fmt::format("{} at x = 1 {}", uy, ux), "1"};
  }

  return pn;
}

/// Group k's fit (erf, or power with its alternative space), its report appended.
FitGroupResult fit_group(const FitJobOptions& o, const io::GroupedData& g, std::size_t k, std::string& report) {
  const bool erf = o.model == FitModel::kErf;
  FitGroupResult gr;
  gr.group = g.labels[k];
  std::vector<double> x = g.x[k], y = g.y[k], s = g.sigma[k];
  std::string note;
  if (erf) {
    gr.fit = fit::fit_erf(x, y, s, o.fit);
  } else {
    bool have_ref = true;
    if (!std::isnan(o.subtract_at)) {
      double s0 = 0;
      have_ref = fit::subtract_at(x, y, s, o.subtract_at, o.subtract_rtol, &gr.y0, &s0);
      if (have_ref)
        note = fmt::format(" (y - y(x={}) with y(x={}) = {:.6g})", format_number_or_empty(o.subtract_at),
                           format_number_or_empty(o.subtract_at), gr.y0);
    }
    if (!have_ref) {
      gr.fit.status = fit::FitStatus::kTooFewPoints;
      gr.fit.message = fmt::format("no point at x = {} to subtract", format_number_or_empty(o.subtract_at));
    } else {
      gr.fit = fit::fit_power(x, y, s, o.space, o.fit);
      const auto other = o.space == fit::PowerSpace::kLinear ? fit::PowerSpace::kLog : fit::PowerSpace::kLinear;
      gr.alternative = fit::fit_power(x, y, s, other, o.fit);
      gr.has_alternative = true;
    }
  }
  const std::string title = fmt::format("{} {}{}", model_name(o.model),
                                        o.group_column.empty() ? std::string("(all rows)")
                                                               : o.group_column + " = " + gr.group,
                                        note);
  report += fmt::format("== {}: status {}{}\n", title, fit::status_name(gr.fit.status),
                            gr.fit.message.empty() ? "" : " (" + gr.fit.message + ")");
  if (gr.fit.has_result) report += fit::fit_report(gr.fit.result, title);
  if (gr.has_alternative && gr.alternative.has_result) {
    const bool alt_log = o.space == fit::PowerSpace::kLinear;
    const auto& a = gr.alternative.result;
    report += fmt::format("    for comparison, {} fit: A = {:.6g} +/- {:.3g}, k = {:.6g} +/- {:.3g} (status {})\n",
                              alt_log ? "log-log straight-line" : "linear-space NLS", a.values[0],
                              a.std_errors[0], a.values[1], a.std_errors[1],
                              fit::status_name(gr.alternative.status));
  }
  report += "\n";
  return gr;
}

/// The header of the three tables: the standard block and every option.
core::Metadata fit_metadata(const FitJobOptions& o, const core::Metadata& header, const io::GroupedData& g, bool erf) {
  // Header: the standard block and every option.
  core::Metadata meta = header;
  meta.emplace_back("fit_model", model_name(o.model));
  meta.emplace_back("input", o.input.string());
  meta.emplace_back("x_column", o.x_column);
  meta.emplace_back("y_column", o.y_column);
  meta.emplace_back("sigma_column", o.sigma_column.empty() ? "none (unit weights)" : o.sigma_column);
  meta.emplace_back("group_column", o.group_column.empty() ? "none" : o.group_column);
  meta.emplace_back("group_rtol", format_number_or_empty(o.group_rtol));
  meta.emplace_back("absolute_sigma", o.fit.absolute_sigma ? "true" : "false");
  meta.emplace_back("loss", fit::loss_name(o.fit.loss));
  meta.emplace_back("loss_scale", format_number_or_empty(o.fit.loss_scale));
  meta.emplace_back("confidence", format_number_or_empty(o.fit.confidence));
  meta.emplace_back("interval", o.fit.absolute_sigma ? "value +/- z*SE (normal quantile)"
                                                     : "value +/- t(dof)*SE (Student t quantile)");
  meta.emplace_back("bootstrap", std::to_string(o.fit.bootstrap));
  meta.emplace_back("seed", std::to_string(o.fit.seed));
  meta.emplace_back("tolerance", format_number_or_empty(o.fit.tolerance));
  meta.emplace_back("max_iterations", std::to_string(o.fit.max_iterations));
  if (erf) {
    meta.emplace_back("model", "y = rc0 + (rcinf - rc0) * (1 + erf((x - phi_c)/W))/2; W = sqrt(2) * Gaussian sigma");
  } else {
    meta.emplace_back("model", "y = A * x^k");
    meta.emplace_back("space", o.space == fit::PowerSpace::kLog ? "log" : "linear");
    meta.emplace_back("subtract_at",
                      std::isnan(o.subtract_at) ? "none" : format_number_or_empty(o.subtract_at));
  }
  if (g.skipped_rows > 0) meta.emplace_back("skipped_rows_status_not_ok", std::to_string(g.skipped_rows));

  return meta;
}

/// The long table: a row per group and parameter, with its interval.
void write_long(std::ostream& out, const FitJobOptions& o, const core::Metadata& meta, const ParameterNames& pn,
                const std::vector<FitGroupResult>& groups) {
  const std::vector<std::string>& names = pn.names;
  const std::vector<std::string>& units = pn.units;
  const bool boot = o.fit.bootstrap > 0;
  std::vector<std::string> cols = {"group", "parameter", "value", "std_error", "ci_low", "ci_high", "unit"};
  if (boot) {
    cols.push_back("boot_low");
    cols.push_back("boot_high");
  }
  io::CsvWriter w(out, meta, cols);
  for (const auto& gr : groups) {
    if (!gr.fit.has_result) continue;
    const auto& r = gr.fit.result;
    for (std::size_t k = 0; k < names.size(); ++k) {
      std::vector<std::string> row = {gr.group, names[k], format_number_or_empty(r.values[k]),
                                      format_number_or_empty(r.std_errors[k]),
                                      format_number_or_empty(r.ci_low[k]),
                                      format_number_or_empty(r.ci_high[k]), units[k]};
      if (boot) {
        row.push_back(format_number_or_empty(r.boot_low[k]));
        row.push_back(format_number_or_empty(r.boot_high[k]));
      }
      w.row(row);
    }
  }
}

/// The wide table: a row per group, every parameter and its SE in columns with units.
void write_wide(std::ostream& out, const core::Metadata& meta, const ParameterNames& pn,
                const std::vector<FitGroupResult>& groups) {
  const std::vector<std::string>& names = pn.names;
  const std::vector<std::string>& units = pn.units;
  core::Metadata wm = meta;
  std::vector<std::string> cols = {"group"};
  // Units in the column names (rcinf_m, phi_c_rad, W_se_rad) where the parameter's unit
  // is the suffix of an input column; a dimensionless or unknown unit leaves the bare
  // name (k, or rc0 of a y column without a unit suffix). The `# unit_<col>:` lines say it.
  auto suffix = [](const std::string& u) {
    const bool plain = !u.empty() && u != "1" && std::all_of(u.begin(), u.end(), [](char ch) {
      return std::isalnum(static_cast<unsigned char>(ch)) || ch == '_';
    });
    return plain ? "_" + u : std::string();
  };
  for (std::size_t k = 0; k < names.size(); ++k) {
    const std::string value = names[k] + suffix(units[k]), se = names[k] + "_se" + suffix(units[k]);
    cols.push_back(value);
    cols.push_back(se);
    wm.emplace_back("unit_" + value, units[k]);
    wm.emplace_back("unit_" + se, units[k]);
  }
  cols.push_back("status");
  io::CsvWriter w(out, wm, cols);
  for (const auto& gr : groups) {
    std::vector<std::string> row = {gr.group};
    for (std::size_t k = 0; k < names.size(); ++k) {
      row.push_back(gr.fit.has_result ? format_number_or_empty(gr.fit.result.values[k]) : "");
      row.push_back(gr.fit.has_result ? format_number_or_empty(gr.fit.result.std_errors[k]) : "");
    }
    row.push_back(fit::status_name(gr.fit.status));
    w.row(row);
  }
}

/// The summary table: a row per group, its status and the fit's statistics.
void write_fit_summary(std::ostream& out, const core::Metadata& meta, const ParameterNames& pn,
                       const std::vector<FitGroupResult>& groups) {
  const std::vector<std::string>& names = pn.names;
  core::Metadata sm = meta;
  sm.emplace_back("units", "n, p, dof, iterations: counts; chi2 .. cond, corr_*: dimensionless");
  std::vector<std::string> cols = {"group", "status", "message", "n", "p", "dof", "chi2",
                                   "reduced_chi2", "aic", "aicc", "bic", "cond", "cond_scaled",
                                   "iterations", "termination"};
  for (std::size_t a = 0; a < names.size(); ++a)
    for (std::size_t b = a + 1; b < names.size(); ++b) cols.push_back("corr_" + names[a] + "_" + names[b]);
  io::CsvWriter w(out, sm, cols);
  for (const auto& gr : groups) {
    const auto& r = gr.fit.result;
    const bool h = gr.fit.has_result;
    std::vector<std::string> row = {gr.group, fit::status_name(gr.fit.status), gr.fit.message};
    if (h) {
      for (double v : {double(r.n), double(r.p), double(r.dof), r.chi2, r.reduced_chi2, r.aic,
                       r.aicc, r.bic, r.cond, r.cond_scaled, double(r.iterations)})
        row.push_back(format_number_or_empty(v));
      row.push_back(r.termination);
    } else {
      row.insert(row.end(), 12, "");
    }
    const std::size_t p = names.size();
    for (std::size_t a = 0; a < p; ++a)
      for (std::size_t b = a + 1; b < p; ++b)
        row.push_back(h ? format_number_or_empty(r.correlation[a * p + b]) : "");
    w.row(row);
  }
}

}  // namespace

FitJobSummary run_fit_job(const FitJobOptions& o, const core::Metadata& header) {
  o.validate();
  FitJobSummary sum;
  sum.long_csv = o.output;
  sum.wide_csv = sibling_output(o.output, "_wide");
  sum.summary_csv = sibling_output(o.output, "_summary");
  for (const auto& p : {sum.long_csv, sum.wide_csv, sum.summary_csv})
    io::check_output_allowed(p, o.force);
  const io::GroupedData g = io::read_grouped(o.input, o.x_column, o.y_column, o.sigma_column,
                                     o.group_column, o.group_rtol);
  const bool erf = o.model == FitModel::kErf;
  const ParameterNames pn = parameter_names(erf, g);
  for (std::size_t k = 0; k < g.labels.size(); ++k) {
    FitGroupResult gr = fit_group(o, g, k, sum.report);
    if (gr.fit.usable()) ++sum.usable;
    sum.groups.push_back(std::move(gr));
  }
  const core::Metadata meta = fit_metadata(o, header, g, erf);
  io::AtomicOutput out_long(sum.long_csv, o.force), out_wide(sum.wide_csv, o.force),
      out_sum(sum.summary_csv, o.force);
  write_long(out_long.stream(), o, meta, pn, sum.groups);
  write_wide(out_wide.stream(), meta, pn, sum.groups);
  write_fit_summary(out_sum.stream(), meta, pn, sum.groups);
  out_long.commit();
  out_wide.commit();
  out_sum.commit();
  return sum;
}

}  // namespace shearzone::pipeline
