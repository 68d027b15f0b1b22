// The parametric erf collapse: a known alpha is recovered within its interval.
#include <cmath>
#include <vector>

#include <catch2/catch.hpp>

#include "fit/fit_test_util.hpp"
#include "shearzone/fit/erf_collapse.hpp"

using namespace shearzone;
using namespace shearzone::fit;

namespace {
std::vector<ErfCollapseGroup> synthetic(std::uint64_t seed, double alpha, double noise) {
  const std::vector<double> ns = {2, 4, 8, 16, 32};
  const double w0 = 0.15, phic = 0.7, nref = 8.0;  // geometric mean of ns
  testing::Gauss g(seed);
  std::vector<ErfCollapseGroup> out;
  for (double n : ns) {
    ErfCollapseGroup grp;
    grp.label = std::to_string(static_cast<int>(n));
    grp.N = n;
    const std::vector<double> p = {0.010, 0.015 + 0.002 * std::sqrt(n), phic,
                                   w0 * std::pow(n / nref, -alpha)};
    for (int i = 0; i < 14; ++i) {
      const double x = 0.2 + 0.075 * i;
      grp.x.push_back(x);
      grp.y.push_back(ErfTransition{}(p.data(), x) + noise * g());
      grp.sigma.push_back(noise);
    }
    out.push_back(grp);
  }
  return out;
}
}  // namespace

/// A single 95 % interval misses the truth 5 % of the time, so the check runs over
/// 60 seeds: coverage of alpha, W0 and phi_c at least 85 % (binomial(60, 0.95) is
/// below 85 % with probability < 0.2 %), and no estimate further than 4 SE out.
constexpr int kCollapseSeeds = 60;
constexpr double kMinCollapseCoverage = 0.85;
constexpr double kMaxZ = 4.0;

TEST_CASE("erf collapse recovers a known alpha, W0 and phi_c within their intervals", "[fit][collapse_erf]") {
  const double alpha = 0.5;
  const std::vector<double> truth = {0.7, 0.15, alpha};
  std::vector<int> covered(3, 0);
  for (int seed = 1; seed <= kCollapseSeeds; ++seed) {
    const auto groups = synthetic(static_cast<std::uint64_t>(seed), alpha, 2e-4);
    FitOptions o;
    o.absolute_sigma = true;
    const ErfCollapseResult r = fit_erf_collapse(groups, o);
    INFO("seed " << seed << ": " << r.global_message << "\n" << fit_report(r.global, "collapse"));
    REQUIRE(r.global_status == FitStatus::kOk);
    CHECK(r.n_ref == Approx(8.0).epsilon(1e-12));
    CHECK(r.global.values.size() == 3 + 2 * groups.size());
    for (std::size_t k = 0; k < 3; ++k) {
      covered[k] += r.global.ci_low[k] <= truth[k] && truth[k] <= r.global.ci_high[k];
      CHECK(std::fabs(r.global.values[k] - truth[k]) < kMaxZ * r.global.std_errors[k]);
    }
    for (const auto& c : r.per_group) CHECK(c.usable());
  }
  for (std::size_t k = 0; k < 3; ++k) {
    INFO("parameter " << k << ": covered " << covered[k] << " of " << kCollapseSeeds);
    CHECK(covered[k] >= kMinCollapseCoverage * kCollapseSeeds);
  }
}

TEST_CASE("erf collapse needs two different N", "[fit][collapse_erf]") {
  auto groups = synthetic(1, 0.5, 2e-4);
  groups.resize(1);
  CHECK(fit_erf_collapse(groups).global_status == FitStatus::kTooFewPoints);
}
