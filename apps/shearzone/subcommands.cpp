// apps/shearzone/subcommands.cpp: the subcommands of `shearzone`, in one place.
#include "subcommands.hpp"

#include <cstdio>

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
  CLI::App* collapse = root.add_subcommand(
      "collapse",
      "Data collapse of r_c(phi0) curves: erf (parametric, global Ceres fit) or fss "
      "(Houdayer-Hartmann, Nelder-Mead)");
  collapse->require_subcommand(1);
  for (auto& s : add_collapse_erf(*collapse, ctx)) subs.push_back(std::move(s));
  for (auto& s : add_collapse_fss(*collapse, ctx)) subs.push_back(std::move(s));
  return subs;
}

void note_small_beads(const char* who, const char* what, double bead_px, const char* advice) {
  std::fprintf(stderr,
               "%s: note: %s %.1f px across; at 8-12 px per bead the closed loop read r_c up to 0.4 "
               "bead diameters low with MPEG-4 and 0.3-0.65 low with H.264 (docs/sim.md, \"Bead size, codec and "
               "the closed loop\"): %s\n",
               who, what, bead_px, advice);
}

}  // namespace shearzone::apps
