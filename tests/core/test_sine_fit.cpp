// The drive's sine fit (core/sine_fit.hpp), shared by laos, piv's vane phase and the
// profile's angle log.
#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "shearzone/core/error.hpp"
#include "shearzone/core/sine_fit.hpp"
#include "shearzone/core/unset.hpp"

using namespace shearzone;
using Catch::Matchers::StartsWith;

namespace {

constexpr double kPi = std::numbers::pi;

/// x = x0 sin(w t + psi) + c + d (t - t_mid), n samples from t_start at dt.
void sine(double w, double x0, double psi, double c, double d, int n, double t_start, double dt,
          std::vector<double>& t, std::vector<double>& x) {
  t.clear();
  x.clear();
  const double tm = t_start + 0.5 * dt * (n - 1);
  for (int i = 0; i < n; ++i) {
    t.push_back(t_start + dt * i);
    x.push_back(x0 * std::sin(w * t.back() + psi) + c + d * (t.back() - tm));
  }
}

}  // namespace

TEST_CASE("the sine fit finds omega, amplitude, phase, offset and drift of an exact sine from its crossings",
          "[core][sine_fit]") {
  // 3.3 cycles at 0.7 Hz, sampled at 37 Hz, starting at t = 2.1 s: no sample on a crossing.
  const double w = 2 * kPi * 0.7;
  std::vector<double> t, x;
  for (const bool drift : {false, true}) {
    const double d = drift ? 0.004 : 0.0;
    sine(w, 0.3, 1.1, -0.02, d, 175, 2.1, 1.0 / 37, t, x);
    const core::SineFit f = core::fit_sine(t, x, core::kUnset, "log", drift);
    // Exact data: the fit is limited by round-off (1e-9 leaves room for the LDLT's).
    CHECK(f.omega == Approx(w).epsilon(1e-9));
    CHECK(f.x0 == Approx(0.3).epsilon(1e-9));
    CHECK(std::remainder(f.psi - 1.1, 2 * kPi) == Approx(0).margin(1e-8));
    CHECK(f.offset == Approx(-0.02).margin(1e-10));
    CHECK(f.drift_per_s == Approx(d).margin(1e-10));
    CHECK(f.rms < 1e-10);
  }
}

TEST_CASE("the sine fit at a fixed omega is linear: A sin + B cos about the reference time, and its residual",
          "[core][sine_fit]") {
  const double w = 2 * kPi * 0.5;
  std::vector<double> t, x;
  sine(w, 2.0, 0.4, 1.5, 0.0, 60, 0.0, 0.05, t, x);
  for (const double t_ref : {0.0, 1.3}) {
    const core::SineAt s = core::fit_sine_at(t, x, w, t_ref, false);
    // x0 sin(w t + psi) = x0 sin(w (t - t_ref) + psi + w t_ref).
    CHECK(std::hypot(s.A, s.B) == Approx(2.0).epsilon(1e-12));
    CHECK(std::remainder(std::atan2(s.B, s.A) - (0.4 + w * t_ref), 2 * kPi) == Approx(0).margin(1e-12));
    CHECK(s.C == Approx(1.5).epsilon(1e-12));
    CHECK(s.D == 0.0);
    CHECK(s.rss < 1e-20);
  }
  // At a wrong omega the residual is what the fit leaves.
  CHECK(core::fit_sine_at(t, x, 1.1 * w, 0.0, false).rss > 1.0);
}

TEST_CASE("the sine fit refuses a record shorter than one cycle, naming its context", "[core][sine_fit]") {
  std::vector<double> t, x;
  sine(2 * kPi, 1.0, 0.0, 0.0, 0.0, 30, 0.0, 0.02, t, x);  // 0.6 of a cycle
  CHECK_THROWS_WITH(core::fit_sine(t, x, core::kUnset, "angle.csv"),
                    StartsWith("angle.csv: less than one drive cycle"));
  CHECK_THROWS_AS(core::fit_sine(t, x, core::kUnset, "angle.csv"), InputError);
}
