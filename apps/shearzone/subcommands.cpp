// apps/shearzone/subcommands.cpp: the subcommands of `shearzone`, in one place.
#include "subcommands.hpp"

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

}  // namespace shearzone::apps
