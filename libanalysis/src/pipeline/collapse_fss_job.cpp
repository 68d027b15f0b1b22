// `shearzone collapse fss`: read the long table, collapse, write three CSV files.
#include "shearzone/pipeline/collapse_fss_job.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/io/atomic_output.hpp"
#include "shearzone/io/csv.hpp"

namespace shearzone::pipeline {
namespace {

using io::format_number;

std::string window_text(const fit::FssWindow& w) {
  return fmt::format("[{}, {}]", format_number(w.lo), format_number(w.hi));
}

core::Metadata job_metadata(const CollapseFssJobOptions& o, const CollapseFssJobSummary& s,
                            const core::Metadata& header) {
  core::Metadata m = header;
  const auto& f = o.fit;
  const auto& r = s.result;
  m.emplace_back("method", "Houdayer-Hartmann collapse quality S minimised by GSL Nelder-Mead (nmsimplex2)");
  m.emplace_back("scaling", "x_scaled = (x - x_c) L^a, y_scaled = y L^b, dy_scaled = dy L^b");
  m.emplace_back("input", o.input.string());
  m.emplace_back("x_column", o.x_column);
  m.emplace_back("y_column", o.y_column);
  m.emplace_back("dy_column", o.dy_column.empty() ? "none (dy = 1, rescaled so that S_min = 1)" : o.dy_column);
  m.emplace_back("L_column", o.L_column);
  std::string sizes;
  for (double L : s.sizes) {
    if (!sizes.empty()) sizes += ',';
    sizes += format_number(L);
  }
  m.emplace_back("sizes", sizes);
  m.emplace_back("points", std::to_string(s.rows));
  m.emplace_back("x_window", window_text(f.window));
  m.emplace_back("start", fmt::format("x_c={},a={},b={}", format_number(f.start[0]),
                                      format_number(f.start[1]), format_number(f.start[2])));
  m.emplace_back("step", fmt::format("x_c={},a={},b={}", format_number(r.step[0]), format_number(r.step[1]),
                                     format_number(r.step[2])));
  std::string fixed;
  for (std::size_t k = 0; k < 3; ++k)
    if (f.fixed[k]) fixed += (fixed.empty() ? "" : ",") + std::string(fit::fss_param_name(k));
  m.emplace_back("fixed", fixed.empty() ? "none" : fixed);
  m.emplace_back("tolerance_steps", format_number(f.tolerance));
  m.emplace_back("max_iterations", std::to_string(f.max_iterations));
  m.emplace_back("max_restarts", std::to_string(f.max_restarts));
  m.emplace_back("rescale_errors", f.rescale_errors ? "true" : "false");
  m.emplace_back("dy_scale", format_number(r.dy_scale));
  m.emplace_back("errors", f.s_plus_one ? "S+1 (one parameter at a time, others at the optimum)" : "none");
  m.emplace_back("bootstrap", std::to_string(f.bootstrap));
  if (f.bootstrap > 0) {
    m.emplace_back("bootstrap_mode", fit::fss_bootstrap_mode_name(f.bootstrap_mode));
    m.emplace_back("bootstrap_seed", std::to_string(f.seed));
    m.emplace_back("bootstrap_ci_level", format_number(f.ci_level));
    m.emplace_back("bootstrap_ok", std::to_string(r.bootstrap_ok));
    m.emplace_back("bootstrap_failed", std::to_string(r.bootstrap_failed));
  }
  m.emplace_back("S_min", format_number(r.quality.S));
  m.emplace_back("n_terms", std::to_string(r.quality.n_terms));
  m.emplace_back("evaluations", std::to_string(r.evaluations));
  m.emplace_back("restarts", std::to_string(r.restarts));
  m.emplace_back("converged", r.converged ? "true" : "false");
  m.emplace_back("units", "L, x, y, dy: as the input columns; x_scaled: x units * L^a; y_scaled, "
                          "dy_scaled, Y, dY: y units * L^b; S, term: dimensionless (1)");
  return m;
}

void write_params(std::ostream& os, const core::Metadata& meta, const CollapseFssJobOptions& o,
                  const fit::FssFitResult& r) {
  io::CsvWriter w(os, meta,
                  {"parameter", "value", "err_low", "err_high", "boot_ci_low", "boot_ci_high", "fixed"});
  for (std::size_t k = 0; k < 3; ++k)
    w.row(std::vector<std::string>{
        fit::fss_param_name(k), format_number(r.best[k]), io::format_number_nan_empty(r.err_low[k]),
        io::format_number_nan_empty(r.err_high[k]), io::format_number_nan_empty(r.ci_low[k]),
        io::format_number_nan_empty(r.ci_high[k]), o.fit.fixed[k] ? "1" : "0"});
  w.row(std::vector<std::string>{"S_min", format_number(r.quality.S), "", "", "", "", ""});
  w.row(std::vector<std::string>{"n_terms", std::to_string(r.quality.n_terms), "", "", "", "", ""});
}

void write_points(std::ostream& os, const core::Metadata& meta, const std::vector<fit::FssPoint>& pts) {
  io::CsvWriter w(os, meta, {"L", "x", "y", "dy", "x_scaled", "y_scaled", "dy_scaled", "in_window"});
  for (const auto& p : pts)
    w.row(std::vector<std::string>{format_number(p.L), format_number(p.x), format_number(p.y),
                                   format_number(p.dy), format_number(p.x_scaled), format_number(p.y_scaled),
                                   format_number(p.dy_scaled), p.in_window ? "1" : "0"});
}

void write_master(std::ostream& os, const core::Metadata& meta, std::vector<fit::FssPoint> pts) {
  std::stable_sort(pts.begin(), pts.end(),
                   [](const fit::FssPoint& a, const fit::FssPoint& b) { return a.x_scaled < b.x_scaled; });
  io::CsvWriter w(os, meta, {"x_scaled", "y_scaled", "dy_scaled", "L", "Y", "dY", "in_window", "term"});
  for (const auto& p : pts)
    w.row(std::vector<std::string>{format_number(p.x_scaled), format_number(p.y_scaled),
                                   format_number(p.dy_scaled), format_number(p.L),
                                   io::format_number_nan_empty(p.Y), io::format_number_nan_empty(p.dY),
                                   p.in_window ? "1" : "0", io::format_number_nan_empty(p.term)});
}

}  // namespace

std::vector<std::string> collapse_fss_output_names() {
  return {"collapse_fss_params.csv", "collapse_fss_points.csv", "collapse_fss_master.csv"};
}

void CollapseFssJobOptions::validate() const {
  if (input.empty()) throw ConfigError("collapse fss: no input file");
  if (x_column.empty() || y_column.empty() || L_column.empty())
    throw ConfigError("collapse fss: the x, y and L column names are required (--x, --y, --L)");
  if (out_dir.empty()) throw ConfigError("collapse fss: no output folder");
  for (double L : sizes)
    if (!(L > 0.0) || !std::isfinite(L))
      throw ConfigError(fmt::format("collapse fss: --sizes: L = {} must be > 0", L));
  fit.validate();
}

CollapseFssJobSummary run_collapse_fss_job(const CollapseFssJobOptions& o, const core::Metadata& header) {
  o.validate();
  // Refuse existing outputs before any work.
  io::AtomicOutputSet outs(o.out_dir, o.force);
  for (const auto& name : collapse_fss_output_names()) outs.check(name);

  const io::CsvTable t = io::read_csv(o.input);
  const std::string src = o.input.string();
  // Columns first (a missing one names the header line), then the cells.
  const std::size_t cx = t.column_index(o.x_column), cy = t.column_index(o.y_column),
                    cL = t.column_index(o.L_column);
  const std::size_t cdy = o.dy_column.empty() ? 0 : t.column_index(o.dy_column);
  if (t.num_rows() == 0)
    throw InputError(fmt::format("{}:{}: no data rows after the header row", src, t.header_line));

  std::vector<double> L, x, y, dy;
  for (std::size_t r = 0; r < t.num_rows(); ++r) {
    const double Lv = t.number(r, cL);
    if (!(Lv > 0.0))
      throw InputError(fmt::format("{}:{}: column \"{}\": \"{}\" must be > 0 (a system size)", src,
                                   t.row_lines[r], o.L_column, t.rows[r][cL]));
    const double xv = t.number(r, cx), yv = t.number(r, cy);
    double dyv = 1.0;
    if (!o.dy_column.empty()) {
      dyv = t.number(r, cdy);
      if (!(dyv > 0.0))
        throw InputError(fmt::format("{}:{}: column \"{}\": \"{}\" must be > 0 (an error bar)", src,
                                     t.row_lines[r], o.dy_column, t.rows[r][cdy]));
    }
    if (!o.sizes.empty() && std::find(o.sizes.begin(), o.sizes.end(), Lv) == o.sizes.end()) continue;
    L.push_back(Lv);
    x.push_back(xv);
    y.push_back(yv);
    dy.push_back(dyv);
  }
  for (double s : o.sizes)
    if (std::find(L.begin(), L.end(), s) == L.end())
      throw ConfigError(
          fmt::format("collapse fss: --sizes: no row of {} has {} = {}", src, o.L_column, format_number(s)));

  CollapseFssJobSummary sum;
  sum.unit_errors = o.dy_column.empty();
  const fit::FssDataSet data = fit::make_fss_dataset(L, x, y, sum.unit_errors ? std::vector<double>{} : dy);
  sum.rows = data.num_points();
  for (const auto& c : data.curves) sum.sizes.push_back(c.L);

  fit::FssFitOptions fo = o.fit;
  if (sum.unit_errors) fo.rescale_errors = true;
  sum.result = fit::fit_fss_collapse(data, fo);

  // Points and master curve with the (possibly rescaled) errors.
  fit::FssDataSet shown = data;
  for (auto& c : shown.curves)
    for (auto& e : c.dy) e *= sum.result.dy_scale;
  const auto pts = fit::fss_points(shown, sum.result.best, fo.window);

  CollapseFssJobOptions shown_opts = o;
  shown_opts.fit = fo;
  const core::Metadata meta = job_metadata(shown_opts, sum, header);
  const auto names = collapse_fss_output_names();
  write_params(outs.add(names[0]).stream(), meta, shown_opts, sum.result);
  write_points(outs.add(names[1]).stream(), meta, pts);
  write_master(outs.add(names[2]).stream(), meta, pts);
  outs.commit_all();
  sum.outputs = outs.final_paths();
  return sum;
}

}  // namespace shearzone::pipeline
