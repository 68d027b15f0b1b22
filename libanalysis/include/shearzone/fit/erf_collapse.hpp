// shearzone/fit/erf_collapse.hpp: the parametric data collapse of r_c(phi0; N)
// curves (`shearzone collapse erf`).
//
// 1. Each group (chain length N) gets its own erf fit (models.hpp) and is rescaled
//    with it: r~ = (rc − rc0)/(rcinf − rc0), phi~ = (phi0 − phi_c)/W, so that all
//    groups fall on the master curve ½(1 + erf(phi~)).
// 2. One global least-squares fit over all groups: phi_c shared, rc0 and rcinf per
//    group, and W(N) = W0·(N/N_ref)^(−α) with N_ref the geometric mean of the
//    groups' N. Parameters: phi_c, W0 (fitted as ln W0), alpha, then rc0_<g>,
//    rcinf_<g> per group; W0 and α come with SEs and intervals directly.
#pragma once

#include <string>
#include <vector>

#include "shearzone/fit/models.hpp"

namespace shearzone::fit {

struct ErfCollapseGroup {
  std::string label;
  double N = 0.0;  ///< > 0
  std::vector<double> x, y, sigma;  ///< sigma empty: unit weights
};

struct ErfCollapseResult {
  std::vector<CurveFit> per_group;  ///< own erf fit of each group
  double n_ref = 0.0;               ///< geometric mean of N
  FitResult global;                 ///< phi_c, W0, alpha, rc0_<g>, rcinf_<g>...
  FitStatus global_status = FitStatus::kNoConvergence;
  std::string global_message;
  /// W(N) of the global fit.
  double width(double N) const;
};

/// Needs at least two groups with distinct N; otherwise the global status is
/// kTooFewPoints (the per-group fits are still done).
ErfCollapseResult fit_erf_collapse(const std::vector<ErfCollapseGroup>& groups,
                                   const FitOptions& options = {});

}  // namespace shearzone::fit
