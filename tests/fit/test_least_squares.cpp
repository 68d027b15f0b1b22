// fit::solve(): the generic entry point (dual numbers, covariance, loss, bootstrap).
#include <cmath>
#include <vector>

#include <catch2/catch.hpp>

#include "fit/fit_test_util.hpp"
#include "shearzone/core/error.hpp"
#include "shearzone/fit/models.hpp"

using namespace shearzone;
using namespace shearzone::fit;

namespace {
/// Agreement of closed-form and fitted values: a few hundred ulp of the result.
constexpr double kTight = 1e-10;

struct Redundant {  // y = (a + b) x: only a + b is determined
  static constexpr int kParams = 2;
  template <class T>
  T operator()(const T* p, double x) const {
    return (p[0] + p[1]) * x;
  }
};
}  // namespace

TEST_CASE("dual numbers give exact derivatives", "[fit]") {
  using D = Dual<2>;
  const D a = D::variable(0.3, 0), b = D::variable(1.7, 1);
  const D f = erf(a / b) * exp(b) + pow(2.0, a) - log(b) * sqrt(a);
  const double h = 2.0 / std::sqrt(std::numbers::pi) * std::exp(-(0.3 / 1.7) * (0.3 / 1.7));
  const double dfa = h / 1.7 * std::exp(1.7) + std::log(2.0) * std::pow(2.0, 0.3) -
                     std::log(1.7) * 0.5 / std::sqrt(0.3);
  const double dfb = -h * 0.3 / (1.7 * 1.7) * std::exp(1.7) + std::erf(0.3 / 1.7) * std::exp(1.7) -
                     std::sqrt(0.3) / 1.7;
  CHECK(f.d[0] == Approx(dfa).epsilon(kTight));
  CHECK(f.d[1] == Approx(dfb).epsilon(kTight));
}

TEST_CASE("a straight line reproduces the closed-form least-squares solution", "[fit]") {
  const std::vector<double> x = {0, 1, 2, 3, 4, 5}, y = {1.1, 2.9, 5.2, 6.8, 9.1, 11.0};
  const FitResult r = solve(curve_problem(Line{}, x, y, {}, {"a", "b"}), {0.0, 0.0});
  REQUIRE(r.usable);
  REQUIRE(r.covariance_ok);
  // Closed form: b = Sxy/Sxx, a = ybar - b xbar, SE(b) = s / sqrt(Sxx).
  double xb = 2.5, yb = 0, sxx = 0, sxy = 0;
  for (double v : y) yb += v / 6.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    sxx += (x[i] - xb) * (x[i] - xb);
    sxy += (x[i] - xb) * (y[i] - yb);
  }
  const double b = sxy / sxx, a = yb - b * xb;
  double rss = 0;
  for (std::size_t i = 0; i < x.size(); ++i) rss += std::pow(y[i] - a - b * x[i], 2);
  CHECK(r.values[0] == Approx(a).epsilon(kTight));
  CHECK(r.values[1] == Approx(b).epsilon(kTight));
  CHECK(r.std_errors[1] == Approx(std::sqrt(rss / 4.0 / sxx)).epsilon(kTight));
  CHECK(r.chi2 == Approx(rss).epsilon(kTight));
  CHECK(r.dof == 4);
  CHECK(r.aic == Approx(6 * std::log(rss / 6) + 4).epsilon(kTight));
  CHECK(r.bic == Approx(6 * std::log(rss / 6) + 2 * std::log(6.0)).epsilon(kTight));
  CHECK(r.aicc == Approx(r.aic + 2.0 * 2 * 3 / 3).epsilon(kTight));
  CHECK(r.quantile == Approx(2.7764451051977987).epsilon(1e-9));  // t(0.975, 4)
  CHECK(r.correlation[1] == Approx(-xb / std::sqrt(sxx / 6 + xb * xb)).epsilon(1e-9));
}

TEST_CASE("absolute sigma: covariance is not rescaled", "[fit]") {
  const std::vector<double> x = {0, 1, 2, 3}, y = {0.0, 1.5, 1.9, 3.2}, s = {0.5, 0.5, 0.5, 0.5};
  FitOptions o;
  o.absolute_sigma = true;
  const FitResult r = solve(curve_problem(Line{}, x, y, s, {"a", "b"}), {0.0, 1.0}, o);
  // SE(b) = sigma / sqrt(Sxx) with Sxx = 5.
  CHECK(r.std_errors[1] == Approx(0.5 / std::sqrt(5.0)).epsilon(kTight));
  CHECK(r.quantile == Approx(1.959963984540054).epsilon(1e-9));  // normal quantile
}

TEST_CASE("a rank-deficient Jacobian gives a singular covariance, no standard errors", "[fit]") {
  const std::vector<double> x = {1, 2, 3, 4}, y = {2.1, 3.9, 6.2, 7.8};
  const FitResult r = solve(curve_problem(Redundant{}, x, y, {}, {"a", "b"}), {1.0, 0.5});
  REQUIRE(r.usable);
  CHECK_FALSE(r.covariance_ok);
  CHECK(std::isnan(r.std_errors[0]));
  CHECK(r.values[0] + r.values[1] == Approx(1.99).epsilon(1e-10));
}

TEST_CASE("a robust loss down-weights an outlier", "[fit]") {
  std::vector<double> x, y;
  for (int i = 0; i < 12; ++i) {
    x.push_back(i);
    y.push_back(1.0 + 0.5 * i + (i % 2 ? 0.05 : -0.05));
  }
  y[6] += 20.0;
  const FitResult plain = solve(curve_problem(Line{}, x, y, {}, {"a", "b"}), {0, 0});
  FitOptions o;
  o.loss = Loss::kCauchy;
  o.loss_scale = 0.2;
  const FitResult robust = solve(curve_problem(Line{}, x, y, {}, {"a", "b"}), {0, 0}, o);
  // The outlier moves the plain slope by ~0.1; the robust one stays within 0.01.
  CHECK(std::fabs(plain.values[1] - 0.5) > 0.05);
  CHECK(std::fabs(robust.values[1] - 0.5) < 0.01);
}

TEST_CASE("the residual bootstrap is deterministic for a seed", "[fit]") {
  const std::vector<double> truth = {1.0, 3.0, 0.5, 0.15};
  std::vector<double> x, y;
  testing::Gauss g(7);
  for (int i = 0; i < 15; ++i) {
    x.push_back(0.05 * i + 0.1);
    y.push_back(ErfTransition{}(truth.data(), x.back()) + 0.05 * g());
  }
  FitOptions o;
  o.bootstrap = 200;
  o.seed = 42;
  const CurveFit a = fit_erf(x, y, {}, o), b = fit_erf(x, y, {}, o);
  REQUIRE(a.usable());
  CHECK(a.result.bootstrap_samples + a.result.bootstrap_failures == 200);
  CHECK(a.result.boot_low == b.result.boot_low);
  CHECK(a.result.boot_high == b.result.boot_high);
  for (std::size_t k = 0; k < 4; ++k) {
    CHECK(a.result.boot_low[k] < a.result.values[k]);
    CHECK(a.result.boot_high[k] > a.result.values[k]);
  }
  o.seed = 43;
  CHECK(fit_erf(x, y, {}, o).result.boot_low != a.result.boot_low);
}

TEST_CASE("malformed problems and options are ConfigError", "[fit]") {
  const std::vector<double> x = {1, 2, 3}, y = {1, 2, 3};
  CHECK_THROWS_AS(solve(curve_problem(Line{}, x, y, {1.0, 0.0, 1.0}, {"a", "b"}), {0, 0}), ConfigError);
  CHECK_THROWS_AS(solve(curve_problem(Line{}, x, y, {}, {"a", "b"}), {0}), ConfigError);
  FitOptions o;
  o.loss_scale = -1;
  CHECK_THROWS_AS(solve(curve_problem(Line{}, x, y, {}, {"a", "b"}), {0, 0}, o), ConfigError);
  CHECK_THROWS_AS(parse_loss("tukey"), ConfigError);
}
