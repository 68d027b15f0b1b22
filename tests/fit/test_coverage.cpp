// Coverage of the 95 % intervals over 400 seeded synthetic data sets, and their
// width compared with the actual spread of the estimates.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "fit/fit_test_util.hpp"
#include "shearzone/fit/models.hpp"

using namespace shearzone;
using namespace shearzone::fit;

namespace {

constexpr int kSeeds = 400;
/// Binomial(400, 0.95) has SD 1.1 %; [91.5 %, 98.5 %] is about ±3 SD around 95 %.
constexpr double kMinCoverage = 0.915;
constexpr double kMaxCoverage = 0.985;
/// Median CI width over the central 95 % range of the estimates across seeds (the
/// width a calibrated interval should have): at most 1.5 (not needlessly wide).
constexpr double kMaxWidthRatio = 1.5;
/// ...and at least 0.6 (a ratio far below 1 would mean intervals that are too
/// narrow, which the coverage check also catches).
constexpr double kMinWidthRatio = 0.6;

double quantile(std::vector<double> v, double f) {
  std::sort(v.begin(), v.end());
  const double pos = f * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<std::size_t>(pos);
  const std::size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (pos - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

struct Tally {
  std::vector<std::string> names;
  std::vector<double> truth;
  std::vector<int> covered;
  std::vector<std::vector<double>> est, width;
  int fits = 0;
  void add(const FitResult& r) {
    ++fits;
    for (std::size_t k = 0; k < truth.size(); ++k) {
      covered[k] += (r.ci_low[k] <= truth[k] && truth[k] <= r.ci_high[k]) ? 1 : 0;
      est[k].push_back(r.values[k]);
      width[k].push_back(r.ci_high[k] - r.ci_low[k]);
    }
  }
  explicit Tally(std::vector<std::string> n, std::vector<double> t)
      : names(std::move(n)), truth(std::move(t)), covered(truth.size(), 0), est(truth.size()),
        width(truth.size()) {}
  void check(const char* label) const {
    REQUIRE(fits == kSeeds);
    for (std::size_t k = 0; k < truth.size(); ++k) {
      const double cov = static_cast<double>(covered[k]) / fits;
      const double spread = quantile(est[k], 0.975) - quantile(est[k], 0.025);
      const double ratio = quantile(width[k], 0.5) / spread;
      std::printf("coverage %-22s %-6s %.1f %%  median CI width / 95 %% spread = %.2f\n", label,
                  names[k].c_str(), 100.0 * cov, ratio);
      INFO(label << " " << names[k] << ": coverage " << cov << ", width ratio " << ratio);
      CHECK(cov >= kMinCoverage);
      CHECK(cov <= kMaxCoverage);
      CHECK(ratio <= kMaxWidthRatio);
      CHECK(ratio >= kMinWidthRatio);
    }
  }
};

}  // namespace

TEST_CASE("erf fit: 95 % intervals cover the truth (400 seeds, sigma estimated)", "[fit][coverage]") {
  // 13 phi0 points spanning both plateaus; noise 3 % of the step; sigma unknown
  // (estimated from the residuals, t quantile with 9 dof).
  const std::vector<double> truth = {2.0, 5.0, 0.7, 0.2};
  const double noise = 0.1;
  std::vector<double> x;
  for (int i = 0; i < 13; ++i) x.push_back(0.1 + 0.1 * i);
  Tally t({"rc0", "rcinf", "phi_c", "W"}, truth);
  for (int seed = 1; seed <= kSeeds; ++seed) {
    testing::Gauss g(static_cast<std::uint64_t>(seed));
    std::vector<double> y;
    for (double xi : x) y.push_back(ErfTransition{}(truth.data(), xi) + noise * g());
    const CurveFit c = fit_erf(x, y, {});
    INFO("seed " << seed << ": " << status_name(c.status) << " " << c.message);
    REQUIRE(c.usable());
    t.add(c.result);
  }
  t.check("erf");
}

TEST_CASE("power law: 95 % intervals cover the truth (400 seeds)", "[fit][coverage]") {
  // 6 chain lengths N = 1..32, 5 % relative noise with known sigma.
  const std::vector<double> truth = {0.3, -0.5};
  const std::vector<double> n = {1, 2, 4, 8, 16, 32};
  const double rel = 0.05;
  Tally lin({"A", "k"}, truth), lg({"A", "k"}, truth), est({"A", "k"}, truth);
  FitOptions absolute;
  absolute.absolute_sigma = true;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    testing::Gauss g(static_cast<std::uint64_t>(1000 + seed));
    std::vector<double> y, s;
    for (double xi : n) {
      const double yt = PowerLaw{}(truth.data(), xi);
      y.push_back(yt * (1.0 + rel * g()));
      s.push_back(rel * yt);
    }
    const CurveFit a = fit_power(n, y, s, PowerSpace::kLinear, absolute);
    const CurveFit b = fit_power(n, y, s, PowerSpace::kLog, absolute);
    const CurveFit c = fit_power(n, y, s, PowerSpace::kLinear);
    INFO("seed " << seed << ": " << a.message << " " << b.message << " " << c.message);
    REQUIRE(a.usable());
    REQUIRE(b.usable());
    REQUIRE(c.usable());
    lin.add(a.result);
    lg.add(b.result);
    est.add(c.result);
  }
  lin.check("power linear, abs sigma");
  lg.check("power log, abs sigma");
  est.check("power linear, est sigma");
}
