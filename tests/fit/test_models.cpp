// The erf and power-law fits: starting values, recovery, degeneracy statuses.
#include <cmath>
#include <vector>

#include <catch2/catch.hpp>

#include "fit/fit_test_util.hpp"
#include "shearzone/fit/models.hpp"

using namespace shearzone;
using namespace shearzone::fit;

namespace {
/// Noise-free data: the fit must return the truth to near round-off.
constexpr double kExact = 1e-7;

std::vector<double> grid(double a, double b, int n) {
  std::vector<double> x;
  for (int i = 0; i < n; ++i) x.push_back(a + (b - a) * i / (n - 1));
  return x;
}
std::vector<double> erf_data(const std::vector<double>& x, const std::vector<double>& p) {
  std::vector<double> y;
  for (double v : x) y.push_back(ErfTransition{}(p.data(), v));
  return y;
}
/// The erf fit of erf_data(x, q) with Gaussian noise of SD `noise` (seeded), its status
/// and message shown on failure.
CurveFit fit_noisy_erf(const std::vector<double>& x, const std::vector<double>& q, double noise,
                       std::uint64_t seed) {
  testing::Gauss g(seed);
  auto y = erf_data(x, q);
  for (double& v : y) v += noise * g();
  return fit_erf(x, y, {});
}

}  // namespace

TEST_CASE("erf starting values follow the documented rules", "[fit]") {
  const std::vector<double> p = {1.0, 3.0, 0.5, 0.2};
  const auto x = grid(0.0, 1.0, 101);
  const auto s = erf_start(x, erf_data(x, p));
  CHECK(s[0] == Approx(1.0).epsilon(1e-3));
  CHECK(s[1] == Approx(3.0).epsilon(1e-3));
  CHECK(s[2] == Approx(0.5).margin(0.005));          // 50 % crossing
  CHECK(s[3] == Approx(0.2).epsilon(0.03));          // W = sqrt(2) x (x84 - x16)/2
}

TEST_CASE("erf fit recovers a noise-free transition, also a decreasing one", "[fit]") {
  for (const std::vector<double>& p : {std::vector<double>{1.0, 3.0, 0.5, 0.2},
                                      std::vector<double>{4.0, 2.5, 0.9, 0.05}}) {
    const auto x = grid(0.1, 1.5, 15);
    const CurveFit c = fit_erf(x, erf_data(x, p), {});
    INFO(c.message);
    // Noise-free: chi2 = 0 and the covariance is 0 too, but the fit is fine.
    REQUIRE(c.has_result);
    for (std::size_t k = 0; k < 4; ++k) CHECK(c.result.values[k] == Approx(p[k]).epsilon(kExact));
  }
}

TEST_CASE("erf degeneracies are statuses", "[fit]") {
  const std::vector<double> p = {1.0, 3.0, 0.5, 0.1};
  SECTION("fewer points than parameters (+1)") {
    const auto x = grid(0.0, 1.0, 4);
    CHECK(fit_erf(x, erf_data(x, p), {}).status == FitStatus::kTooFewPoints);
    FitOptions o;
    o.absolute_sigma = true;
    const auto x3 = grid(0.0, 1.0, 3);
    CHECK(fit_erf(x3, erf_data(x3, p), {0.1, 0.1, 0.1}, o).status == FitStatus::kTooFewPoints);
  }
  SECTION("flat data") {
    const auto x = grid(0.0, 1.0, 12);
    CHECK(fit_erf(x, std::vector<double>(12, 2.5), {}).status == FitStatus::kFlatData);
  }
  SECTION("transition outside the sampled range") {
    // Only the rising start of a transition centred at 1.4 is sampled (x <= 1).
    const std::vector<double> q = {1.0, 3.0, 1.4, 0.4};
    const auto x = grid(0.0, 1.0, 12);
    const CurveFit c = fit_noisy_erf(x, q, 0.002, 3);
    INFO(status_name(c.status) << " " << c.message);
    CHECK((c.status == FitStatus::kTransitionOutsideRange || c.status == FitStatus::kNoConvergence ||
           c.status == FitStatus::kSingularCovariance));
    CHECK_FALSE(c.usable());
  }
  SECTION("transition sharper than the sampling") {
    // W = 0.01 against a spacing of 0.09: at most one point inside phi_c +- W.
    const std::vector<double> q = {1.0, 3.0, 0.52, 0.01};
    const auto x = grid(0.0, 1.0, 12);
    const CurveFit c = fit_noisy_erf(x, q, 0.01, 4);
    INFO(status_name(c.status) << " " << c.message);
    CHECK(c.status == FitStatus::kTransitionUnresolved);
    CHECK_FALSE(c.usable());
  }
  SECTION("no convergence") {
    const auto x = grid(0.0, 1.0, 12);
    testing::Gauss g(5);
    auto y = erf_data(x, p);
    for (double& v : y) v += 0.05 * g();
    FitOptions o;
    o.max_iterations = 1;
    o.polish_steps = 0;
    const CurveFit c = fit_erf(x, y, {}, o);
    CHECK(c.status == FitStatus::kNoConvergence);
    CHECK_FALSE(c.usable());
  }
}

TEST_CASE("power law: linear and log space, degeneracies", "[fit]") {
  const std::vector<double> x = {1, 2, 4, 8, 16};
  std::vector<double> y;
  for (double v : x) y.push_back(0.4 * std::pow(v, -0.7));
  for (auto space : {PowerSpace::kLinear, PowerSpace::kLog}) {
    const CurveFit c = fit_power(x, y, {}, space);
    REQUIRE(c.has_result);
    CHECK(c.result.values[0] == Approx(0.4).epsilon(kExact));
    CHECK(c.result.values[1] == Approx(-0.7).epsilon(kExact));
  }
  CHECK(fit_power({1, 2}, {1, 2}, {}, PowerSpace::kLinear).status == FitStatus::kTooFewPoints);
  CHECK(fit_power({0, 1, 2, 3}, {1, 2, 3, 4}, {}, PowerSpace::kLinear).status ==
        FitStatus::kNonPositiveValues);
  CHECK(fit_power({1, 2, 3, 4}, {1, -2, 3, 4}, {}, PowerSpace::kLog).status ==
        FitStatus::kNonPositiveValues);
  CHECK(fit_power({1, 2, 3, 4}, {0, 0, 0, 0}, {}, PowerSpace::kLinear).status ==
        FitStatus::kFlatData);
  CHECK_THROWS(parse_power_space("loglog"));
}

TEST_CASE("subtract_at removes the reference point and propagates its sigma", "[fit]") {
  std::vector<double> x = {1, 2, 4, 8}, y = {1.0, 1.5, 2.0, 3.0}, s = {0.3, 0.4, 0.4, 0.4};
  double y0 = 0, s0 = 0;
  REQUIRE(subtract_at(x, y, s, 1.0, 1e-9, &y0, &s0));
  CHECK(x == std::vector<double>{2, 4, 8});
  CHECK(y == std::vector<double>{0.5, 1.0, 2.0});
  CHECK(s0 == Approx(0.3));
  CHECK(s[0] == Approx(0.5));  // sqrt(0.4^2 + 0.3^2)
  std::vector<double> e;
  CHECK_FALSE(subtract_at(x, y, e, 1.0, 1e-9));
}
