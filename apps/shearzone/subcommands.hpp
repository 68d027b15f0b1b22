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

/// The `shearzone` command: its root (-q, -v, --version) and every subcommand.
class Command {
 public:
  explicit Command(Context& ctx);
  CLI::App& app() { return app_; }
  /// Runs the subcommand parsed, at the level -q and -v set.
  int dispatch();

 private:
  Context& ctx_;
  CLI::App app_;
  bool quiet_ = false, verbose_ = false;
  std::vector<Subcommand> subs_;
};

/// Runs `words` (a subcommand and its arguments, as typed after `shearzone`) in this
/// process with `ctx` (the Python module): the command line's parsing, conversion and
/// job, or ctx.capture. Throws what the job throws (run_words); returns the exit code.
int run_in_process(const std::vector<std::string>& words, Context& ctx);

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
/// `shearzone report`.
std::vector<Subcommand> add_report(CLI::App& root, Context& ctx);

/// `shearzone width`.
std::vector<Subcommand> add_width(CLI::App& root, Context& ctx);

/// `shearzone synth particles|beads`.
std::vector<Subcommand> add_synth(CLI::App& root, Context& ctx);

/// Small beads in the image: the closed loop reads r_c low with H.264 (docs/sim.md, "Bead
/// size, codec and the closed loop": at 8-12 px per bead 0.13-0.52 d low with H.264,
/// within 0.25 d with MPEG-4; within 0.25 d from 15 px with either). Below this size
/// `sim render` and `sim check` say so on stderr. Large beads need no note: `piv`
/// sizes its windows to them.
constexpr double kSmallBeadPx = 14.0;

/// The same limit on `piv`'s texture size (autocorrelation half-width x
/// piv::kBeadDiameterPerHalfWidth), which reads rendered beads of 12, 15 and 18 px as
/// 10.9, 13.9 and 16.5 px (`sim check` on data-samples/sim/vane_cup.toml): 13 px of
/// texture is about 14 px of bead. Particles measure under piv::kSmallBeadMinPx: no note.
constexpr double kSmallTexturePx = 13.0;

/// The note above, as "<who>: note: <what> ... px across; ..." on stderr. `advice`
/// ends the line (how to film larger beads).
void note_small_beads(const char* who, const char* what, double bead_px, const char* advice);

}  // namespace shearzone::apps
