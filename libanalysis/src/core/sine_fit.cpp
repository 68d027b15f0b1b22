// See shearzone/core/sine_fit.hpp.
#include "shearzone/core/sine_fit.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <Eigen/Dense>
#include <fmt/format.h>

#include "shearzone/core/check.hpp"
#include "shearzone/core/error.hpp"

namespace shearzone::core {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kTwoPi = 2.0 * kPi;
/// Schmitt-trigger hysteresis for the crossings that guess ω, fraction of the record's
/// half range.
constexpr double kHysteresis = 0.02;

/// The linear fit at fixed ω on times already taken about the reference (tau).
SineAt linear_sine(const std::vector<double>& tau, const std::vector<double>& x, double omega, bool drift) {
  SineAt s;
  if (drift) {
    Eigen::Matrix4d N = Eigen::Matrix4d::Zero();
    Eigen::Vector4d b = Eigen::Vector4d::Zero();
    for (std::size_t i = 0; i < tau.size(); ++i) {
      const Eigen::Vector4d r(std::sin(omega * tau[i]), std::cos(omega * tau[i]), 1.0, tau[i]);
      N += r * r.transpose();
      b += r * x[i];
    }
    const Eigen::Vector4d c = N.ldlt().solve(b);
    s = {c[0], c[1], c[2], c[3], 0.0};
  } else {
    Eigen::Matrix3d N = Eigen::Matrix3d::Zero();
    Eigen::Vector3d b = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < tau.size(); ++i) {
      const Eigen::Vector3d r(std::sin(omega * tau[i]), std::cos(omega * tau[i]), 1.0);
      N += r * r.transpose();
      b += r * x[i];
    }
    const Eigen::Vector3d c = N.ldlt().solve(b);
    s = {c[0], c[1], c[2], 0.0, 0.0};
  }
  for (std::size_t i = 0; i < tau.size(); ++i) {
    const double e = x[i] - (s.A * std::sin(omega * tau[i]) + s.B * std::cos(omega * tau[i]) + s.C + s.D * tau[i]);
    s.rss += e * e;
  }
  return s;
}

/// ω from the record's crossings of its mid level in both directions (half periods).
double omega_from_crossings(const std::vector<double>& t, const std::vector<double>& x, const std::string& context) {
  const auto [mn, mx] = std::minmax_element(x.begin(), x.end());
  const double level = 0.5 * (*mn + *mx), half = 0.5 * (*mx - *mn);
  const double h = kHysteresis * half;
  std::vector<double> tc;
  int state = 0;  // −1 below, +1 above, 0 not yet known
  std::size_t last_side = 0;
  for (std::size_t i = 0; i < t.size(); ++i) {
    const int s_now = x[i] > level + h ? 1 : (x[i] < level - h ? -1 : 0);
    if (s_now == 0) continue;
    if (state != 0 && s_now != state) {
      // The crossing lies between last_side and i: the last pair that brackets level.
      std::size_t j = i;
      while (j > last_side + 1 && (x[j - 1] - level) * s_now > 0) --j;
      const double a0 = x[j - 1] - level, a1 = x[j] - level;
      tc.push_back(a1 == a0 ? t[j] : t[j - 1] + (t[j] - t[j - 1]) * (-a0) / (a1 - a0));
    }
    state = s_now;
    last_side = i;
  }
  if (tc.size() < 3)
    throw InputError(fmt::format("{}: less than one drive cycle ({} crossings of the mid level); "
                                 "expected at least one complete cycle",
                                 context, tc.size()));
  return kPi * static_cast<double>(tc.size() - 1) / (tc.back() - tc.front());
}

}  // namespace

SineAt fit_sine_at(const std::vector<double>& t, const std::vector<double>& x, double omega, double t_ref,
                   bool drift) {
  SHEARZONE_CHECK(t.size() == x.size() && t.size() >= (drift ? 4u : 3u));
  std::vector<double> tau(t.size());
  for (std::size_t i = 0; i < t.size(); ++i) tau[i] = t[i] - t_ref;
  return linear_sine(tau, x, omega, drift);
}

SineFit fit_sine(const std::vector<double>& t, const std::vector<double>& x, double omega_guess,
                 const std::string& context, bool drift) {
  const std::size_t n = t.size();
  SHEARZONE_CHECK(n == x.size() && n >= 4);
  const double tm = 0.5 * (t.front() + t.back());
  std::vector<double> tau(n);
  for (std::size_t i = 0; i < n; ++i) tau[i] = t[i] - tm;
  const double w0 = std::isnan(omega_guess) ? omega_from_crossings(t, x, context) : omega_guess;
  const double span = t.back() - t.front();
  const double ncyc = std::max(1.0, w0 * span / kTwoPi);
  // Golden-section search of the RSS over the main lobe around the guess.
  double lo = w0 * (1 - 0.5 / ncyc * 0.5), hi = w0 * (1 + 0.5 / ncyc * 0.5);
  const double g = (std::sqrt(5.0) - 1) / 2;
  double a = hi - g * (hi - lo), b = lo + g * (hi - lo);
  double fa = linear_sine(tau, x, a, drift).rss, fb = linear_sine(tau, x, b, drift).rss;
  for (int it = 0; it < 60 && (hi - lo) > 1e-13 * w0; ++it) {
    if (fa < fb) {
      hi = b, b = a, fb = fa, a = hi - g * (hi - lo), fa = linear_sine(tau, x, a, drift).rss;
    } else {
      lo = a, a = b, fa = fb, b = lo + g * (hi - lo), fb = linear_sine(tau, x, b, drift).rss;
    }
  }
  double w = 0.5 * (lo + hi);
  SineAt s = linear_sine(tau, x, w, drift);
  // Gauss-Newton polishing of every parameter (IEEE-1057 four-parameter fit).
  for (int it = 0; it < 50; ++it) {
    Eigen::Matrix4d N = Eigen::Matrix4d::Zero();
    Eigen::Vector4d r = Eigen::Vector4d::Zero();
    Eigen::Matrix<double, 5, 5> N5 = Eigen::Matrix<double, 5, 5>::Zero();
    Eigen::Matrix<double, 5, 1> r5 = Eigen::Matrix<double, 5, 1>::Zero();
    for (std::size_t i = 0; i < n; ++i) {
      const double sn = std::sin(w * tau[i]), cs = std::cos(w * tau[i]);
      const Eigen::Vector4d j(sn, cs, 1.0, tau[i] * (s.A * cs - s.B * sn));
      const double e = x[i] - (s.A * sn + s.B * cs + s.C + s.D * tau[i]);
      if (drift) {
        const Eigen::Matrix<double, 5, 1> j5(sn, cs, 1.0, j[3], tau[i]);
        N5 += j5 * j5.transpose();
        r5 += j5 * e;
      } else {
        N += j * j.transpose();
        r += j * e;
      }
    }
    const double dw = drift ? N5.ldlt().solve(r5)[3] : N.ldlt().solve(r)[3];
    const double w_new = w + dw;
    if (!std::isfinite(w_new) || w_new <= 0) break;
    const SineAt s_new = linear_sine(tau, x, w_new, drift);
    if (s_new.rss > s.rss * (1 + 1e-12) + 1e-300) break;
    const bool done = std::abs(dw) <= 1e-15 * w;
    w = w_new;
    s = s_new;
    if (done) break;
  }
  SineFit f;
  f.omega = w;
  f.x0 = std::hypot(s.A, s.B);
  f.offset = s.C;  // at the middle of the record
  f.drift_per_s = s.D;
  f.rms = std::sqrt(s.rss / static_cast<double>(n));
  // x − C = x0 sin(ω τ + ψ_m) with ψ_m = atan2(B, A); refer ψ to t = 0 (θ = ωt + ψ).
  f.psi = std::atan2(s.B, s.A) - w * tm;
  return f;
}

}  // namespace shearzone::core
