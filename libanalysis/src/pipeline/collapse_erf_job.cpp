#include "shearzone/pipeline/collapse_erf_job.hpp"

#include <cmath>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/io/grouped_table.hpp"
#include "shearzone/io/atomic_output.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/pipeline/fit_job.hpp"

namespace shearzone::pipeline {
namespace {
using io::format_number_or_empty;
}  // namespace

void CollapseErfJobOptions::validate() const {
  fit.validate();
  if (x_column.empty() || y_column.empty() || group_column.empty())
    throw ConfigError("collapse erf: --x, --y and --group are required");
  if (!(group_rtol >= 0)) throw ConfigError(fmt::format("--group-rtol {}: must be >= 0", group_rtol));
  if (grid_points < 2) throw ConfigError("collapse erf: grid points must be >= 2");
}

CollapseErfJobSummary run_collapse_erf_job(const CollapseErfJobOptions& o,
                                           const core::Metadata& header) {
  o.validate();
  io::AtomicOutputSet outs(o.out_dir, o.force);
  for (const char* f : {"collapsed.csv", "master.csv", "parameters.csv"}) outs.check(f);
  const io::GroupedData g = io::read_grouped(o.input, o.x_column, o.y_column, o.sigma_column,
                                     o.group_column, o.group_rtol);
  std::vector<fit::ErfCollapseGroup> groups;
  for (std::size_t k = 0; k < g.labels.size(); ++k) {
    if (!(g.group_values[k] > 0))
      throw InputError(fmt::format("{}: column \"{}\": group \"{}\" is not a positive chain length N",
                                   o.input.string(), o.group_column, g.labels[k]));
    groups.push_back({g.labels[k], g.group_values[k], g.x[k], g.y[k], g.sigma[k]});
  }
  CollapseErfJobSummary sum;
  sum.labels = g.labels;
  sum.result = fit::fit_erf_collapse(groups, o.fit);
  const auto& r = sum.result;
  const bool gok = r.global_status == fit::FitStatus::kOk;

  for (std::size_t k = 0; k < groups.size(); ++k) {
    const auto& c = r.per_group[k];
    sum.report += fmt::format("== erf {} = {}: status {}{}\n", o.group_column, g.labels[k],
                              fit::status_name(c.status), c.message.empty() ? "" : " (" + c.message + ")");
    if (c.has_result) sum.report += fit::fit_report(c.result, fmt::format("{} = {}", o.group_column, g.labels[k]));
  }
  sum.report += fmt::format("== global collapse: status {}{}; N_ref = {:.6g}\n",
                            fit::status_name(r.global_status),
                            r.global_message.empty() ? "" : " (" + r.global_message + ")", r.n_ref);
  if (r.global.usable) sum.report += fit::fit_report(r.global, "global erf collapse, W = W0 (N/N_ref)^-alpha");

  const std::string ux = g.x_unit.empty() ? "as x" : g.x_unit, uy = g.y_unit.empty() ? "as y" : g.y_unit;
  core::Metadata meta = header;
  meta.emplace_back("input", o.input.string());
  meta.emplace_back("x_column", o.x_column);
  meta.emplace_back("y_column", o.y_column);
  meta.emplace_back("sigma_column", o.sigma_column.empty() ? "none (unit weights)" : o.sigma_column);
  meta.emplace_back("group_column", o.group_column);
  meta.emplace_back("group_rtol", format_number_or_empty(o.group_rtol));
  meta.emplace_back("absolute_sigma", o.fit.absolute_sigma ? "true" : "false");
  meta.emplace_back("loss", fit::loss_name(o.fit.loss));
  meta.emplace_back("loss_scale", format_number_or_empty(o.fit.loss_scale));
  meta.emplace_back("confidence", format_number_or_empty(o.fit.confidence));
  meta.emplace_back("bootstrap", std::to_string(o.fit.bootstrap));
  meta.emplace_back("seed", std::to_string(o.fit.seed));
  meta.emplace_back("model", "y = rc0_g + (rcinf_g - rc0_g) (1 + erf((x - phi_c)/W(N)))/2, W(N) = W0 (N/N_ref)^-alpha");
  meta.emplace_back("N_ref", format_number_or_empty(r.n_ref));
  meta.emplace_back("global_status", fit::status_name(r.global_status));
  if (r.global.usable) {
    meta.emplace_back("global_chi2", format_number_or_empty(r.global.chi2));
    meta.emplace_back("global_reduced_chi2", format_number_or_empty(r.global.reduced_chi2));
    meta.emplace_back("global_dof", std::to_string(r.global.dof));
    meta.emplace_back("global_aic", format_number_or_empty(r.global.aic));
    meta.emplace_back("global_bic", format_number_or_empty(r.global.bic));
    meta.emplace_back("global_cond", format_number_or_empty(r.global.cond));
  }

  {
    core::Metadata m = meta;
    m.emplace_back("units", "phi_tilde, r_tilde: dimensionless; x in " + ux + ", y in " + uy);
    io::CsvWriter w(outs.add("collapsed.csv").stream(), m,
                    {"group", "N", o.x_column, o.y_column, "phi_tilde", "r_tilde", "r_tilde_sigma",
                     "phi_tilde_global", "r_tilde_global", "status"});
    for (std::size_t k = 0; k < groups.size(); ++k) {
      const auto& c = r.per_group[k];
      if (!c.has_result) continue;
      const auto& v = c.result.values;
      const std::size_t a = 3 + 2 * k;
      for (std::size_t i = 0; i < groups[k].x.size(); ++i) {
        const double x = groups[k].x[i], y = groups[k].y[i];
        const double s = groups[k].sigma.empty() ? std::nan("") : groups[k].sigma[i];
        double pg = std::nan(""), rg = std::nan("");
        if (gok) {
          const auto& gv = r.global.values;
          pg = (x - gv[0]) / r.width(groups[k].N);
          rg = (y - gv[a]) / (gv[a + 1] - gv[a]);
        }
        w.row(std::vector<std::string>{
            g.labels[k], format_number_or_empty(groups[k].N), format_number_or_empty(x),
            format_number_or_empty(y), format_number_or_empty((x - v[2]) / v[3]),
            format_number_or_empty((y - v[0]) / (v[1] - v[0])),
            format_number_or_empty(s / std::fabs(v[1] - v[0])), format_number_or_empty(pg),
            format_number_or_empty(rg), fit::status_name(c.status)});
      }
    }
  }
  {
    core::Metadata m = meta;
    m.emplace_back("units", "dimensionless");
    io::CsvWriter w(outs.add("master.csv").stream(), m, {"phi_tilde", "r_tilde"});
    for (int i = 0; i < o.grid_points; ++i) {
      const double x = -3.0 + 6.0 * i / (o.grid_points - 1);
      w.row(std::vector<double>{x, 0.5 * (1.0 + std::erf(x))});
    }
  }
  {
    io::CsvWriter w(outs.add("parameters.csv").stream(), meta,
                    {"scope", "parameter", "value", "std_error", "ci_low", "ci_high", "unit", "status"});
    if (r.global.usable)
      for (std::size_t k = 0; k < r.global.values.size(); ++k) {
        const std::string unit = k == 0 ? ux : k == 1 ? ux : k == 2 ? "1" : uy;
        w.row(std::vector<std::string>{
            "global", r.global.names[k], format_number_or_empty(r.global.values[k]),
            format_number_or_empty(r.global.std_errors[k]), format_number_or_empty(r.global.ci_low[k]),
            format_number_or_empty(r.global.ci_high[k]), unit, fit::status_name(r.global_status)});
      }
    const std::vector<std::string> names = {"rc0", "rcinf", "phi_c", "W"};
    const std::vector<std::string> units = {uy, uy, ux, ux};
    for (std::size_t k = 0; k < groups.size(); ++k) {
      const auto& c = r.per_group[k];
      if (!c.has_result) continue;
      for (std::size_t j = 0; j < 4; ++j)
        w.row(std::vector<std::string>{
            g.labels[k], names[j], format_number_or_empty(c.result.values[j]),
            format_number_or_empty(c.result.std_errors[j]), format_number_or_empty(c.result.ci_low[j]),
            format_number_or_empty(c.result.ci_high[j]), units[j], fit::status_name(c.status)});
    }
  }
  outs.commit_all();
  return sum;
}

}  // namespace shearzone::pipeline
