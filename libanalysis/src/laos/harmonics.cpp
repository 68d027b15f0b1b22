// Quadrature-weighted least-squares harmonics and the derived LAOS measures.
#include "shearzone/laos/harmonics.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <Eigen/Dense>
#include <fmt/format.h>

#include "shearzone/core/check.hpp"
#include "shearzone/core/error.hpp"

namespace shearzone::laos {

namespace {
constexpr double kTwoPi = 2.0 * std::numbers::pi;

double wrap_2pi(double a) {
  double r = std::fmod(a, kTwoPi);
  if (r < 0) r += kTwoPi;
  // Round-off just below 2π (or a tiny negative value wrapped) reads as 0.
  if (kTwoPi - r < 1e-12) r = 0.0;
  return r;
}
}  // namespace

double HarmonicFit::evaluate(double theta) const {
  double s = offset + drift_per_cycle * (theta - theta_mid) / kTwoPi;
  for (int n = 1; n <= M; ++n)
    s += amplitude * (Kp[n] * std::sin(n * theta) + Kpp[n] * std::cos(n * theta));
  return s;
}

double HarmonicFit::odd_sin_part(double theta) const {
  double s = 0;
  for (int n = 1; n <= M; n += 2) s += amplitude * Kp[n] * std::sin(n * theta);
  return s;
}

double HarmonicFit::odd_cos_part(double theta) const {
  double s = 0;
  for (int n = 1; n <= M; n += 2) s += amplitude * Kpp[n] * std::cos(n * theta);
  return s;
}

void add_trapezoid_weights(const std::vector<double>& theta, double a, double b,
                           std::vector<double>& w) {
  const std::size_t n = theta.size();
  SHEARZONE_CHECK(w.size() == n && n >= 2 && a < b);
  SHEARZONE_CHECK(theta.front() <= a && theta.back() >= b);
  for (std::size_t i = 0; i + 1 < n; ++i) {
    const double t0 = theta[i], t1 = theta[i + 1];
    const double h = t1 - t0;
    if (!(h > 0)) continue;
    const double lo = std::max(t0, a), hi = std::min(t1, b);
    if (!(hi > lo)) continue;
    // ∫_lo^hi of the linear interpolant f_i (1 − s) + f_{i+1} s, s = (θ − t0)/h:
    // weights of f_i and f_{i+1} are ∫(1 − s) dθ and ∫ s dθ over [lo, hi].
    const double s0 = (lo - t0) / h, s1 = (hi - t0) / h;
    const double int_s = 0.5 * (s1 * s1 - s0 * s0) * h;
    w[i] += (hi - lo) - int_s;
    w[i + 1] += int_s;
  }
}

HarmonicFit fit_harmonics(const std::vector<double>& theta, const std::vector<double>& response,
                          const std::vector<double>& weights, double amplitude,
                          const HarmonicFitOptions& options) {
  SHEARZONE_CHECK(theta.size() == response.size() && theta.size() == weights.size());
  const int M = options.max_harmonic;
  SHEARZONE_CHECK(M >= 1);
  if (!(amplitude > 0) || !std::isfinite(amplitude))
    throw InputError(fmt::format("harmonic fit: drive amplitude {} is not positive", amplitude));
  std::vector<std::size_t> rows;
  double tmin = 0, tmax = 0;
  for (std::size_t i = 0; i < theta.size(); ++i) {
    if (!(weights[i] > 0)) continue;
    if (rows.empty()) tmin = tmax = theta[i];
    tmin = std::min(tmin, theta[i]);
    tmax = std::max(tmax, theta[i]);
    rows.push_back(i);
  }
  const int p = 2 * M + 1 + (options.drift ? 1 : 0);
  const auto n = static_cast<Eigen::Index>(rows.size());
  if (n < p + 1)
    throw InputError(fmt::format("harmonic fit: {} samples for {} parameters (M = {}); expected at "
                                 "least {}",
                                 n, p, M, p + 1));
  HarmonicFit f;
  f.M = M;
  f.amplitude = amplitude;
  f.theta_mid = 0.5 * (tmin + tmax);
  f.samples = rows.size();
  Eigen::MatrixXd X(n, p);
  Eigen::VectorXd y(n), w(n);
  for (Eigen::Index r = 0; r < n; ++r) {
    const std::size_t i = rows[static_cast<std::size_t>(r)];
    const double sw = std::sqrt(weights[i]);
    w[r] = weights[i];
    for (int k = 1; k <= M; ++k) {
      X(r, 2 * (k - 1)) = sw * amplitude * std::sin(k * theta[i]);
      X(r, 2 * (k - 1) + 1) = sw * amplitude * std::cos(k * theta[i]);
    }
    X(r, 2 * M) = sw;
    if (options.drift) X(r, 2 * M + 1) = sw * (theta[i] - f.theta_mid) / kTwoPi;
    y[r] = sw * response[i];
  }
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(X);
  const Eigen::VectorXd beta = qr.solve(y);
  // Weighted mean squared residual, corrected for the fitted parameters.
  const Eigen::VectorXd res = y - X * beta;  // = √w (r − model)
  const double wsum = w.sum();
  const double sigma2 =
      res.squaredNorm() / wsum * static_cast<double>(n) / static_cast<double>(n - p);
  f.sigma = std::sqrt(sigma2);
  // Sandwich covariance: A⁻¹ B A⁻¹ σ̂², A = RᵀR, B = Xsᵀ diag(w) Xs.
  const Eigen::MatrixXd R = qr.matrixQR().topRows(p).triangularView<Eigen::Upper>();
  const Eigen::MatrixXd Rinv =
      R.triangularView<Eigen::Upper>().solve(Eigen::MatrixXd::Identity(p, p));
  const Eigen::MatrixXd Ainv = Rinv * Rinv.transpose();
  const Eigen::MatrixXd B = X.transpose() * w.asDiagonal() * X;
  const Eigen::MatrixXd cov = Ainv * B * Ainv * sigma2;
  f.Kp.assign(static_cast<std::size_t>(M) + 1, 0.0);
  f.Kpp = f.Kp_se = f.Kpp_se = f.Kp;
  for (int k = 1; k <= M; ++k) {
    f.Kp[k] = beta[2 * (k - 1)];
    f.Kpp[k] = beta[2 * (k - 1) + 1];
    f.Kp_se[k] = std::sqrt(std::max(0.0, cov(2 * (k - 1), 2 * (k - 1))));
    f.Kpp_se[k] = std::sqrt(std::max(0.0, cov(2 * (k - 1) + 1, 2 * (k - 1) + 1)));
  }
  f.offset = beta[2 * M];
  f.offset_se = std::sqrt(std::max(0.0, cov(2 * M, 2 * M)));
  if (options.drift) {
    f.drift_per_cycle = beta[2 * M + 1];
    f.drift_se = std::sqrt(std::max(0.0, cov(2 * M + 1, 2 * M + 1)));
  }
  return f;
}

Measures derive_measures(const HarmonicFit& f, double omega) {
  Measures m;
  m.M = f.M;
  m.omega = omega;
  const int M = f.M;
  m.K1p = f.Kp[1];
  m.K1pp = f.Kpp[1];
  m.K1p_se = f.Kp_se[1];
  m.K1pp_se = f.Kpp_se[1];
  m.tan_delta = m.K1pp / m.K1p;
  const double I1 = std::hypot(f.Kp[1], f.Kpp[1]);
  const double d1 = std::atan2(f.Kpp[1], f.Kp[1]);
  m.I_over_I1.assign(static_cast<std::size_t>(M) + 1, 0.0);
  m.Phi = m.e = m.v = m.I_over_I1;
  double sum_nK = 0, sum_e = 0, sum_visc_M = 0, sum_Kpp = 0;
  for (int n = 1; n <= M; ++n) {
    m.I_over_I1[n] = std::hypot(f.Kp[n], f.Kpp[n]) / I1;
    m.Phi[n] = wrap_2pi(std::atan2(f.Kpp[n], f.Kp[n]) - n * d1);
    if (n % 2 == 0) continue;
    const double sgn = ((n - 1) / 2) % 2 == 0 ? 1.0 : -1.0;
    m.e[n] = f.Kp[n] * sgn;
    m.v[n] = f.Kpp[n] / omega;  // NaN when ω is unknown
    sum_nK += n * f.Kp[n];
    sum_e += m.e[n];
    sum_visc_M += n * f.Kpp[n] * sgn;
    sum_Kpp += f.Kpp[n];
  }
  m.K_M = sum_nK;
  m.K_L = sum_e;
  m.S = (m.K_L - m.K_M) / m.K_L;
  m.eta_M = sum_visc_M / omega;
  m.eta_L = sum_Kpp / omega;
  // T is a ratio: ω cancels, so it is available without a frequency.
  m.T = (sum_Kpp - sum_visc_M) / sum_Kpp;
  if (M >= 3) {
    m.e3_over_e1 = m.e[3] / m.e[1];
    m.v3_over_v1 = f.Kpp[3] / f.Kpp[1];  // = v3/v1, no ω needed
    m.I3_over_I1 = m.I_over_I1[3];
  }
  if (M >= 2) m.I2_over_I1 = m.I_over_I1[2];
  return m;
}

double loop_area(const std::vector<double>& x, const std::vector<double>& r) {
  SHEARZONE_CHECK(x.size() == r.size());
  const std::size_t n = x.size();
  if (n < 2) return 0.0;
  double a = 0;
  for (std::size_t i = 0; i + 1 < n; ++i) a += 0.5 * (r[i] + r[i + 1]) * (x[i + 1] - x[i]);
  a += 0.5 * (r[n - 1] + r[0]) * (x[0] - x[n - 1]);
  return a;
}

}  // namespace shearzone::laos
