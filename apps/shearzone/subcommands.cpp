// apps/shearzone/subcommands.cpp: the subcommands of `shearzone`, in one place.
#include "subcommands.hpp"

#include <cstdio>

#include "shearzone/core/version.hpp"

namespace shearzone::apps {

std::vector<Subcommand> add_subcommands(CLI::App& root, Context& ctx) {
  std::vector<Subcommand> subs = add_bench(root, ctx);
  for (auto& s : add_piv(root, ctx)) subs.push_back(std::move(s));
  for (auto& s : add_synth(root, ctx)) subs.push_back(std::move(s));
  for (auto& s : add_profile(root, ctx)) subs.push_back(std::move(s));
  for (auto& s : add_width(root, ctx)) subs.push_back(std::move(s));
  for (auto& s : add_fit(root, ctx)) subs.push_back(std::move(s));
  for (auto& s : add_laos(root, ctx)) subs.push_back(std::move(s));
  for (auto& s : add_sim(root, ctx)) subs.push_back(std::move(s));
  for (auto& s : add_study(root, ctx)) subs.push_back(std::move(s));
  for (auto& s : add_report(root, ctx)) subs.push_back(std::move(s));
  CLI::App* collapse = root.add_subcommand(
      "collapse",
      "Data collapse of r_c(phi0) curves: erf (parametric, global Ceres fit) or fss "
      "(Houdayer-Hartmann, Nelder-Mead)");
  collapse->require_subcommand(1);
  for (auto& s : add_collapse_erf(*collapse, ctx)) subs.push_back(std::move(s));
  for (auto& s : add_collapse_fss(*collapse, ctx)) subs.push_back(std::move(s));
  return subs;
}

Command::Command(Context& ctx)
    : ctx_(ctx),
      app_("shearzone: experimental rheology of granular chains (PIV, profiles, fits, LAOS, contact dynamics)") {
  app_.name("shearzone");
  app_.set_version_flag("--version", std::string("shearzone ") + kVersion);
  app_.require_subcommand(1);
  app_.fallthrough();  // -q/-v may follow the subcommand
  app_.add_flag("-q,--quiet", quiet_, "Only errors on stderr; no progress, no summary");
  app_.add_flag("-v,--verbose", verbose_, "More detail on stderr");
  subs_ = add_subcommands(app_, ctx_);
}

int Command::dispatch() {
  ctx_.level = quiet_ ? core::LogLevel::kQuiet : (verbose_ ? core::LogLevel::kVerbose : core::LogLevel::kNormal);
  for (auto& s : subs_)
    if (s.app->parsed()) return s.run();
  return kExitUsage;  // unreachable: CLI11 requires a subcommand
}

int run_in_process(const std::vector<std::string>& words, Context& ctx) {
  Command command(ctx);
  std::vector<std::string> argv{"shearzone"};
  argv.insert(argv.end(), words.begin(), words.end());
  return run_words(command.app(), argv, [&] { return command.dispatch(); });
}

void note_small_beads(const char* who, const char* what, double bead_px, const char* advice) {
  std::fprintf(stderr,
               "%s: note: %s %.1f px across; at 8-12 px per bead the closed loop read r_c within 0.25 "
               "bead diameters with MPEG-4 but 0.13-0.52 low with H.264 (docs/sim.md, \"Bead size, codec and "
               "the closed loop\"): %s\n",
               who, what, bead_px, advice);
}

}  // namespace shearzone::apps
