// apps/shearzone/subcommands.hpp: each subcommand file adds itself to the CLI and
// returns the function that runs it once parsing is done.
#pragma once

#include <functional>

#include <CLI/CLI.hpp>

#include "common/run_app.hpp"

namespace shearzone::apps {

/// A parsed subcommand and the function that runs it (returns an exit code).
struct Subcommand {
  CLI::App* app = nullptr;
  std::function<int()> run;
};

/// Every subcommand of `shearzone` on `root` (main and the study's option check).
std::vector<Subcommand> add_subcommands(CLI::App& root, Context& ctx);

/// `shearzone bench piv`.
std::vector<Subcommand> add_bench(CLI::App& root, Context& ctx);

/// `shearzone collapse erf` (`parent` is the `collapse` subcommand).
std::vector<Subcommand> add_collapse_erf(CLI::App& parent, Context& ctx);

/// `shearzone collapse fss` (`parent` is the `collapse` subcommand).
std::vector<Subcommand> add_collapse_fss(CLI::App& parent, Context& ctx);

/// `shearzone fit erf|power`.
std::vector<Subcommand> add_fit(CLI::App& root, Context& ctx);

/// `shearzone laos`.
std::vector<Subcommand> add_laos(CLI::App& root, Context& ctx);

/// `shearzone piv`.
std::vector<Subcommand> add_piv(CLI::App& root, Context& ctx);

/// `shearzone profile`.
std::vector<Subcommand> add_profile(CLI::App& root, Context& ctx);

/// `shearzone sim`.
std::vector<Subcommand> add_sim(CLI::App& root, Context& ctx);

/// `shearzone sim render` (`sim` is the `sim` subcommand).
std::vector<Subcommand> add_sim_render(CLI::App& sim, Context& ctx);

/// `shearzone study run`.
std::vector<Subcommand> add_study(CLI::App& root, Context& ctx);

/// `shearzone width`.
std::vector<Subcommand> add_width(CLI::App& root, Context& ctx);

/// `shearzone synth particles|beads`.
std::vector<Subcommand> add_synth(CLI::App& root, Context& ctx);

}  // namespace shearzone::apps
