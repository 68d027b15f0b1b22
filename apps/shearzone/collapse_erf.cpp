// `shearzone collapse erf`: per-group erf rescaling and one global erf fit with
// W = W0 (N/N_ref)^-alpha. Flags map onto pipeline::CollapseErfJobOptions.
#include <cstdio>
#include <memory>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/pipeline/collapse_erf_job.hpp"
#include "subcommands.hpp"

namespace shearzone::apps {
namespace {

struct CollapseErfCli {
  pipeline::CollapseErfJobOptions job;
  std::string input, output, config, loss = "none";
};

int run_collapse_erf(CLI::App& c, CollapseErfCli& s, const Context& ctx) {
  configure(c, s.config, {"output", "x", "y", "group"});
  auto& j = s.job;
  j.input = s.input;
  j.out_dir = s.output;
  j.fit.loss = fit::parse_loss(s.loss);
  if (ctx.check_options) {  // the study's option check: no file read
    j.validate();
    return kExitOk;
  }
  const auto sum = pipeline::run_collapse_erf_job(j, ctx.header());
  if (ctx.level == core::LogLevel::kVerbose) std::fputs(sum.report.c_str(), stdout);
  if (ctx.level != core::LogLevel::kQuiet)
    std::printf("collapse erf: %zu groups, global fit %s -> %s%s\n", sum.labels.size(),
                fit::status_name(sum.result.global_status), j.out_dir.string().c_str(),
                ctx.level == core::LogLevel::kVerbose ? "" : " (-v prints the report)");
  if (sum.result.global_status != fit::FitStatus::kOk)
    throw NoResultError(fmt::format("collapse erf: the global fit is not usable ({}: {})",
                                    fit::status_name(sum.result.global_status),
                                    sum.result.global_message));
  return kExitOk;
}

}  // namespace

std::vector<Subcommand> add_collapse_erf(CLI::App& parent, Context& ctx) {
  auto s = std::make_shared<CollapseErfCli>();
  auto& j = s->job;
  CLI::App* c = parent.add_subcommand(
      "erf", "Rescale each N with its own erf fit and fit all N at once with W = W0 (N/N_ref)^-alpha");
  c->add_option("table", s->input, "Input CSV table")->required();
  c->add_option("-o,--output", s->output, "Output folder (collapsed.csv, master.csv, parameters.csv)");
  c->add_option("--config", s->config, "TOML file setting any of these options by long name");
  c->add_flag("--force", j.force, "Replace existing outputs");
  c->add_option("--x", j.x_column, "Column of phi0");
  c->add_option("--y", j.y_column, "Column of r_c");
  c->add_option("--sigma", j.sigma_column, "Column of the uncertainty of r_c (default: unit weights)");
  c->add_option("--group", j.group_column, "Column of the chain length N");
  c->add_option("--group-rtol", j.group_rtol,
                "N values equal within this relative tolerance are one group; range: >= 0")
      ->capture_default_str();
  c->add_flag("--absolute-sigma", j.fit.absolute_sigma, "Sigma are absolute: no reduced-chi-square scaling");
  c->add_option("--loss", s->loss, "Robust loss: none, huber or cauchy")->capture_default_str();
  c->add_option("--loss-scale", j.fit.loss_scale, "Robust loss scale; range: > 0, finite")
      ->capture_default_str();
  c->add_option("--bootstrap", j.fit.bootstrap, "Residual bootstrap resamples (0: none); range: 0..100000")
      ->capture_default_str();
  c->add_option("--seed", j.fit.seed, "Bootstrap seed; range: 0..18446744073709551615")
      ->capture_default_str();
  return {{c, [c, s, &ctx] { return run_collapse_erf(*c, *s, ctx); }}};
}

}  // namespace shearzone::apps
