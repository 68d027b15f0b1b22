// `shearzone fit erf|power`: least-squares fits of a CSV table, per group.
// Flags map onto pipeline::FitJobOptions; --config FILE.toml sets them by long name.
#include <cmath>
#include <cstdio>
#include <memory>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/core/unset.hpp"
#include "shearzone/pipeline/fit_job.hpp"
#include "subcommands.hpp"

namespace shearzone::apps {
namespace {

struct FitCli {
  pipeline::FitJobOptions job;
  std::string input, output, config;
  std::string loss = "none";
  std::string space = "linear";
  double subtract_at = core::kUnset;
};

int run_fit(CLI::App& c, FitCli& s, const Context& ctx) {
  configure(c, s.config, {"output", "x", "y"});
  auto& j = s.job;
  j.input = s.input;
  j.output = s.output;
  j.fit.loss = fit::parse_loss(s.loss);
  if (j.model == pipeline::FitModel::kPower) {
    j.space = fit::parse_power_space(s.space);
    j.subtract_at = s.subtract_at;
  }
  if (ctx.capture) {  // the Python module's arrays: the options, no file
    ctx.capture(j);
    return kExitOk;
  }
  if (ctx.check_options) {  // the study's option check: no file read
    j.validate();
    return kExitOk;
  }
  const auto sum = pipeline::run_fit_job(j, ctx.header());
  // Stdout: a one-line summary; the full report (parameters, intervals, diagnostics
  // per group) with -v. Every number of it is in the CSVs.
  if (ctx.level == core::LogLevel::kVerbose) std::fputs(sum.report.c_str(), stdout);
  if (ctx.level != core::LogLevel::kQuiet) {
    // One group: its parameters belong on the summary line (value +/- standard error).
    std::string params;
    if (sum.groups.size() == 1 && sum.groups[0].fit.status == fit::FitStatus::kOk) {
      const auto& f = sum.groups[0].fit.result;
      for (std::size_t i = 0; i < f.names.size() && i < f.values.size(); ++i)
        params += fmt::format("{}{} = {:.4g} +/- {:.2g}", params.empty() ? ": " : ", ", f.names[i], f.values[i],
                              i < f.std_errors.size() ? f.std_errors[i] : core::kUnset);
    }
    std::printf("fit: %zu of %zu group%s usable%s -> %s, %s, %s%s\n", sum.usable, sum.groups.size(),
                sum.groups.size() == 1 ? "" : "s", params.c_str(), sum.long_csv.string().c_str(),
                sum.wide_csv.string().c_str(), sum.summary_csv.string().c_str(),
                ctx.level == core::LogLevel::kVerbose ? "" : " (-v prints the report)");
    // Several groups: one line each with its parameters (value +/- standard error),
    // the first 20; every number is in the CSVs.
    constexpr std::size_t kMaxGroupLines = 20;
    if (sum.groups.size() > 1 && ctx.level != core::LogLevel::kVerbose) {
      for (std::size_t g = 0; g < sum.groups.size() && g < kMaxGroupLines; ++g) {
        const auto& gr = sum.groups[g];
        std::string line = fmt::format("  {} = {}: {}", j.group_column, gr.group, fit::status_name(gr.fit.status));
        if (gr.fit.status == fit::FitStatus::kOk) {
          const auto& f = gr.fit.result;
          for (std::size_t i = 0; i < f.names.size() && i < f.values.size(); ++i)
            line += fmt::format("{}{} = {:.4g} +/- {:.2g}", i == 0 ? "; " : ", ", f.names[i], f.values[i],
                                i < f.std_errors.size() ? f.std_errors[i] : core::kUnset);
        }
        std::printf("%s\n", line.c_str());
      }
      if (sum.groups.size() > kMaxGroupLines)
        std::printf("  ... %zu more groups in %s\n", sum.groups.size() - kMaxGroupLines,
                    sum.wide_csv.string().c_str());
    }
  }
  if (sum.usable == 0) {
    std::string why;
    for (const auto& g : sum.groups)
      why += fmt::format("{}{}: {}", why.empty() ? "" : "; ", g.group, fit::status_name(g.fit.status));
    throw NoResultError(fmt::format("fit: no group gave a usable fit ({}); statuses written to {}",
                                    why, sum.summary_csv.string()));
  }
  return kExitOk;
}

void add_common(CLI::App* c, FitCli& s) {
  auto& j = s.job;
  c->add_option("table", s.input, "Input CSV table")->required();
  c->add_option("-o,--output", s.output,
                "Long CSV of the parameters; _wide and _summary CSVs are written beside it");
  c->add_option("--config", s.config, "TOML file setting any of these options by long name");
  c->add_flag("--force", j.force, "Replace existing outputs");
  c->add_option("--x", j.x_column, "Column of x");
  c->add_option("--y", j.y_column, "Column of y");
  c->add_option("--sigma", j.sigma_column, "Column of the uncertainty of y (default: unit weights)");
  c->add_option("--group", j.group_column, "Column whose values split the table into fits");
  c->add_option("--group-rtol", j.group_rtol,
                "Numeric group values equal within this relative tolerance are one group; "
                "range: >= 0, finite")
      ->capture_default_str();
  c->add_flag("--absolute-sigma", j.fit.absolute_sigma,
              "Sigma are absolute: no reduced-chi-square scaling, normal quantile");
  c->add_option("--loss", s.loss, "Robust loss: none, huber or cauchy")->capture_default_str();
  c->add_option("--loss-scale", j.fit.loss_scale,
                "Robust loss scale, in weighted-residual units; range: > 0, finite")
      ->capture_default_str();
  c->add_option("--bootstrap", j.fit.bootstrap, "Residual bootstrap resamples (0: none); range: 0..100000")
      ->capture_default_str();
  c->add_option("--seed", j.fit.seed, "Bootstrap seed; range: 0..18446744073709551615")
      ->capture_default_str();
  c->add_option("--confidence", j.fit.confidence, "Confidence level of the intervals; range: 0 < x < 1")
      ->capture_default_str();
}

}  // namespace

std::vector<Subcommand> add_fit(CLI::App& root, Context& ctx) {
  CLI::App* fit = root.add_subcommand(
      "fit", "Least-squares fits per group: erf transition r_c(phi0) or power law y = A x^k");
  fit->require_subcommand(1);

  auto se = std::make_shared<FitCli>();
  se->job.model = pipeline::FitModel::kErf;
  CLI::App* e = fit->add_subcommand(
      "erf", "rc(x) = rc0 + (rcinf - rc0) (1 + erf((x - phi_c)/W))/2 per group");
  add_common(e, *se);

  auto sp = std::make_shared<FitCli>();
  sp->job.model = pipeline::FitModel::kPower;
  CLI::App* p = fit->add_subcommand("power", "y = A x^k per group (NLS in linear space or a log-log line)");
  add_common(p, *sp);
  p->add_option("--space", sp->space, "linear (weighted NLS) or log (straight line in log-log)")
      ->capture_default_str();
  p->add_option("--subtract-at", sp->subtract_at,
                "Fit y - y(x = X); the point at X is removed and its sigma propagated; "
                "range: any finite number");

  return {{e, [e, se, &ctx] { return run_fit(*e, *se, ctx); }},
          {p, [p, sp, &ctx] { return run_fit(*p, *sp, ctx); }}};
}

}  // namespace shearzone::apps
