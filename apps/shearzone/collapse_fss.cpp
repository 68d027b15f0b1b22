// `shearzone collapse fss`: Houdayer-Hartmann finite-size-scaling collapse of curves
// y(x; L). Flags map onto pipeline::CollapseFssJobOptions; --config FILE.toml sets
// them by long name.
#include <cmath>
#include <cstdio>
#include <memory>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/pipeline/collapse_fss_job.hpp"
#include "subcommands.hpp"

namespace shearzone::apps {
namespace {

struct CollapseFssCli {
  pipeline::CollapseFssJobOptions job;
  std::string output, config, mode = "points";
  std::vector<double> window, start, step;
  std::vector<std::string> fix;
  bool no_s_plus_one = false;
};

/// --fix NAME or NAME=VALUE.
void apply_fix(const std::string& spec, fit::FssFitOptions& f) {
  const auto eq = spec.find('=');
  const std::string name = spec.substr(0, eq);
  std::size_t k = 3;
  for (std::size_t i = 0; i < 3; ++i)
    if (name == fit::fss_param_name(i) || (i == 0 && name == "xc")) k = i;
  if (k == 3)
    throw ConfigError(fmt::format("--fix \"{}\": unknown parameter \"{}\"; expected x_c, a or b", spec, name));
  f.fixed[k] = true;
  if (eq != std::string::npos) {
    const std::string v = spec.substr(eq + 1);
    char* end = nullptr;
    const double d = std::strtod(v.c_str(), &end);
    if (v.empty() || end != v.c_str() + v.size() || !std::isfinite(d))
      throw ConfigError(fmt::format("--fix \"{}\": \"{}\" is not a finite number", spec, v));
    f.start[k] = d;
  }
}

std::string err_text(double lo, double hi) {
  if (std::isnan(lo)) return "fixed";
  return fmt::format("-{:.3g} / +{:.3g} (S+1)", lo, hi);
}

int run_collapse_fss(CLI::App& c, CollapseFssCli& s, const Context& ctx) {
  configure(c, s.config, {"output", "x", "y", "L", "start"});
  auto& j = s.job;
  auto& f = j.fit;
  j.out_dir = s.output;
  for (std::size_t k = 0; k < 3; ++k) f.start[k] = s.start[k];
  if (!s.step.empty())
    for (std::size_t k = 0; k < 3; ++k) f.step[k] = s.step[k];
  if (!s.window.empty()) {
    f.window.lo = s.window[0];
    f.window.hi = s.window[1];
  }
  for (const auto& spec : s.fix) apply_fix(spec, f);
  f.bootstrap_mode = fit::fss_bootstrap_mode_from_name(s.mode);
  f.s_plus_one = !s.no_s_plus_one;

  const auto sum = pipeline::run_collapse_fss_job(j, ctx.header());
  if (ctx.level != core::LogLevel::kQuiet) {
    const auto& r = sum.result;
    std::string sizes;
    for (double L : sum.sizes) sizes += (sizes.empty() ? "" : ", ") + fmt::format("{}", L);
    std::printf("collapse fss: %zu sizes (L = %s), %zu points, x window [%g, %g]%s\n",
                sum.sizes.size(), sizes.c_str(), sum.rows, f.window.lo, f.window.hi,
                sum.unit_errors ? fmt::format(", no dy: dy = {:.4g} from the scatter", r.dy_scale).c_str() : "");
    std::printf("collapse fss: S_min = %.6f over %zu terms (%d evaluations, %d restarts%s)\n",
                r.quality.S, r.quality.n_terms, r.evaluations, r.restarts,
                r.converged ? "" : ", NOT converged");
    for (std::size_t k = 0; k < 3; ++k) {
      std::string line = fmt::format("  {:<3} = {:.6g}  {}", fit::fss_param_name(k), r.best[k],
                                     f.s_plus_one || f.fixed[k] ? err_text(r.err_low[k], r.err_high[k]) : "");
      if (!std::isnan(r.ci_low[k]))
        line += fmt::format("  bootstrap {:g}%: [{:.6g}, {:.6g}]", 100 * f.ci_level, r.ci_low[k], r.ci_high[k]);
      std::printf("%s\n", line.c_str());
    }
    if (f.bootstrap > 0)
      std::printf("collapse fss: bootstrap (%s, seed %llu): %zu replicates, %zu failed\n",
                  fit::fss_bootstrap_mode_name(f.bootstrap_mode),
                  static_cast<unsigned long long>(f.seed), r.bootstrap_ok, r.bootstrap_failed);
    std::printf("collapse fss: wrote %zu files to %s\n", sum.outputs.size(), j.out_dir.string().c_str());
  }
  return kExitOk;
}

}  // namespace

std::vector<Subcommand> add_collapse_fss(CLI::App& parent, Context& ctx) {
  auto s = std::make_shared<CollapseFssCli>();
  auto& j = s->job;
  auto& f = j.fit;
  CLI::App* c = parent.add_subcommand(
      "fss", "Houdayer-Hartmann collapse y L^b vs (x - x_c) L^a of a long CSV table (Nelder-Mead; "
             "S+1 and bootstrap errors)");
  c->add_option("input", j.input, "Long CSV table: one row per point")->required();
  c->add_option("-o,--output", s->output, "Output folder (collapse_fss_{params,points,master}.csv)");
  c->add_option("--config", s->config, "TOML file setting any of these options by long name");
  c->add_flag("--force", j.force, "Replace existing outputs");
  c->add_option("--x", j.x_column, "Column of the control parameter x (e.g. phi0_rad, p)");
  c->add_option("--y", j.y_column, "Column of the observable y");
  c->add_option("--dy", j.dy_column,
                "Column of the error of y (none: dy = 1, rescaled so that S_min = 1)");
  c->add_option("--L", j.L_column, "Column of the system size L (e.g. chain length N)");
  c->add_option("--sizes", j.sizes,
                "Use only these L values (comma-separated); range: each > 0, finite")
      ->delimiter(',');
  c->add_option("--x-window", s->window, "Terms of S only for scaled x in [LO, HI]; range: LO < HI")
      ->expected(2)
      ->delimiter(',');
  c->add_option("--start", s->start, "Start point X_C A B of the simplex; range: each finite")
      ->expected(3)
      ->delimiter(',');
  c->add_option("--step", s->step,
                "Initial simplex steps DXC DA DB (default: 1% of the x range, 0.01, 0.01); "
                "range: each > 0, finite")
      ->expected(3)
      ->delimiter(',');
  c->add_option("--fix", s->fix, "Fix a parameter: NAME or NAME=VALUE, NAME in x_c, a, b (repeatable)");
  c->add_option("--tolerance", f.tolerance, "Stop when the simplex size < this, in steps; range: > 0")
      ->capture_default_str();
  c->add_option("--max-iterations", f.max_iterations, "Iterations per simplex run; range: 1..1000000")
      ->capture_default_str();
  c->add_option("--restarts", f.max_restarts,
                "Most restarts from the optimum while S improves; range: 0..1000")
      ->capture_default_str();
  c->add_flag("--rescale-errors", f.rescale_errors, "Scale all dy by sqrt(S_min) so that S_min = 1");
  c->add_flag("--no-s-plus-one", s->no_s_plus_one, "Skip the S+1 errors");
  c->add_option("--bootstrap", f.bootstrap, "Bootstrap replicates (0: none); range: 0..100000")
      ->capture_default_str();
  c->add_option("--bootstrap-mode", s->mode, "Resample points (within each size) or curves")
      ->capture_default_str();
  c->add_option("--seed", f.seed, "Bootstrap seed; range: 0..18446744073709551615")->capture_default_str();
  c->add_option("--ci", f.ci_level, "Bootstrap central interval level; range: 0 < x < 1")
      ->capture_default_str();
  return {{c, [c, s, &ctx] { return run_collapse_fss(*c, *s, ctx); }}};
}

}  // namespace shearzone::apps
