// `shearzone width`: radial profiles -> shear-zone width r_c with a bootstrap interval.
#include <cmath>
#include <cstdio>
#include <memory>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/pipeline/width_job.hpp"
#include "subcommands.hpp"

namespace shearzone::apps {
namespace {

struct WidthCli {
  pipeline::WidthJobOptions job;
  std::vector<std::string> inputs, tags;
  std::string output, config, estimator = "auto";
};

int run_width(CLI::App& c, WidthCli& s, const Context& ctx) {
  configure(c, s.config, {"output"});
  auto& j = s.job;
  j.inputs.assign(s.inputs.begin(), s.inputs.end());
  j.output = s.output;
  j.tags = parse_key_values(s.tags, "--tag");
  j.width.estimator = profile::estimator_from_name(s.estimator);
  if (ctx.check_options) {  // the study's option check: no file read
    j.validate();
    return kExitOk;
  }
  const auto rows = pipeline::run_width_job(j, ctx.header());
  int usable = 0;
  for (const auto& r : rows) {
    usable += r.status == profile::WidthStatus::kOk;
    if (ctx.level != core::LogLevel::kQuiet) {
      // never_below and below_at_vane give bounds, not values.
      const char* rel = r.status == profile::WidthStatus::kNeverBelow    ? ">="
                        : r.status == profile::WidthStatus::kBelowAtVane ? "<="
                                                                          : "=";
      const char* status = profile::width_status_name(r.status);
      if (std::isfinite(r.rc_m))
        std::printf("width: %s: r_c %s %.5g m (%s, %s)\n", r.label.c_str(), rel, r.rc_m, status,
                    profile::estimator_name(r.estimator));
      else
        std::printf("width: %s: no r_c (%s, %s)\n", r.label.c_str(), status, profile::estimator_name(r.estimator));
    }
  }
  if (ctx.level != core::LogLevel::kQuiet)
    std::printf("width: %zu profile%s, %d ok -> %s\n", rows.size(), rows.size() == 1 ? "" : "s",
                usable, j.output.string().c_str());
  if (usable == 0) {
    // Exit 3 with one line (run_app): the statuses, and the advice of the first noise-limited row.
    std::string why;
    for (const auto& r : rows) why += fmt::format("{}{}: {}", why.empty() ? "" : ", ", r.label, profile::width_status_name(r.status));
    for (const auto& r : rows)
      if (!r.advice.empty()) {
        why += "; " + r.advice;
        break;
      }
    // The table is written (every row with its status); the run has no usable result.
    throw NoResultError(fmt::format("{}: no profile gave a usable r_c ({})", j.output.string(), why));
  }
  for (const auto& r : rows)
    if (!r.advice.empty()) std::fprintf(stderr, "shearzone: warning: %s\n", r.advice.c_str());
  return kExitOk;
}

}  // namespace

std::vector<Subcommand> add_width(CLI::App& root, Context& ctx) {
  auto s = std::make_shared<WidthCli>();
  auto& j = s->job;
  CLI::App* c = root.add_subcommand("width", "Shear-zone width r_c of radial profiles -> CSV");
  c->add_option("inputs", s->inputs, "Profile CSVs of `shearzone profile`")->required();
  c->add_option("-o,--output", s->output, "Widths CSV");
  c->add_option("--config", s->config, "TOML file setting any of these options by long name");
  c->add_flag("--force", j.force, "Replace an existing output");
  c->add_option("--tag", s->tags, "N=VALUE or phi0_rad=VALUE for every row (default: from the profile)");
  c->add_option("--vc", j.width.v_c_m_per_s, "Threshold velocity v_c, m/s; range: > 0, finite")
      ->capture_default_str();
  c->add_option("--estimator", s->estimator,
                 "mean-abs (the paper's mean |v|), lockin (phase-locked v_theta amplitude) or auto (lockin where "
                 "mean-abs is noise_limited)")
      ->capture_default_str();
  c->add_option("--noise-factor", j.width.noise_factor, "noise_limited when v_c < this x noise floor; range: >= 0")
      ->capture_default_str();
  c->add_option("--bootstrap", j.width.bootstrap, "Bootstrap resamples (0: no interval); range: 0..1000000")
      ->capture_default_str();
  c->add_option("--confidence", j.width.confidence, "Two-sided confidence level; range: 0 < x < 1")
      ->capture_default_str();
  c->add_option("--seed", j.width.seed, "Bootstrap seed; range: 0..18446744073709551615")->capture_default_str();
  return {{c, [c, s, &ctx] { return run_width(*c, *s, ctx); }}};
}

}  // namespace shearzone::apps
