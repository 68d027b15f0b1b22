#include "shearzone/profile/lockin.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>

#include <Eigen/Dense>
#include <fmt/format.h>

#include "shearzone/core/error.hpp"

namespace shearzone::profile {

namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

/// Points of the uniform phase grid on which a waveform's mean |.| is taken: the
/// trapezoid rule on a periodic function converges fast away from the kinks of |w|
/// at its zeros, where the error is O(1/M^2) (below 1e-5 relative for M = 360).
std::size_t grid_points(int H) { return static_cast<std::size_t>(std::max(360, 48 * H)); }

/// Rows of the instantaneous basis (1, cos theta, sin theta, cos 3 theta, ...) on the grid.
Eigen::MatrixXd grid_basis(int H) {
  const std::size_t M = grid_points(H);
  const int p = H + 2;
  Eigen::MatrixXd X(static_cast<Eigen::Index>(M), p);
  for (std::size_t i = 0; i < M; ++i) {
    const double th = kTwoPi * (static_cast<double>(i) + 0.5) / static_cast<double>(M);
    const auto r = static_cast<Eigen::Index>(i);
    X(r, 0) = 1.0;
    for (int h = 1, c = 1; h <= H; h += 2, c += 2) {
      X(r, c) = std::cos(h * th);
      X(r, c + 1) = std::sin(h * th);
    }
  }
  return X;
}

/// Mean |X beta| and, when wanted, its gradient mean(sign(X beta) X).
/// H = 1 in closed form: with A = sqrt(a^2 + b^2) and u = c/A, the cycle mean of
/// |c + A cos| is |c| for |u| >= 1, else (2/pi)(A sqrt(1 - u^2) + c asin u); its
/// derivatives are (2/pi) asin u in c and (2/pi) sqrt(1 - u^2) in A.
template <class Vec>
double mean_abs_h1(const Vec& beta, Eigen::VectorXd* grad) {
  const double c = beta(0), A = std::hypot(beta(1), beta(2));
  if (!(A > std::abs(c))) {
    if (grad) *grad = Eigen::Vector3d(c > 0 ? 1.0 : (c < 0 ? -1.0 : 0.0), 0.0, 0.0);
    return std::abs(c);
  }
  const double u = c / A, q = std::sqrt(1.0 - u * u), k = 2.0 / std::numbers::pi;
  if (grad) *grad = Eigen::Vector3d(k * std::asin(u), k * q * beta(1) / A, k * q * beta(2) / A);
  return k * (A * q + c * std::asin(u));
}

template <class Mat, class Vec>
double mean_abs(const Mat& X, const Vec& beta, Eigen::VectorXd* grad) {
  if (X.cols() == 3) return mean_abs_h1(beta, grad);
  const Eigen::VectorXd w = X * beta;
  const double M = static_cast<double>(X.rows());
  if (grad) {
    grad->setZero(X.cols());
    for (Eigen::Index i = 0; i < X.rows(); ++i) {
      const double s = w(i) > 0 ? 1.0 : (w(i) < 0 ? -1.0 : 0.0);
      *grad += s * X.row(i).transpose();
    }
    *grad /= M;
  }
  return w.cwiseAbs().sum() / M;
}

}  // namespace

double waveform_mean_abs(const std::vector<double>& coef) {
  if (coef.size() < 3 || coef.size() % 2 == 0)
    throw InternalError("waveform_mean_abs: expected (c0, a1, b1, a3, b3, ...)");
  const int H = static_cast<int>(coef.size()) - 2;
  const Eigen::MatrixXd X = grid_basis(H);
  const Eigen::VectorXd b = Eigen::Map<const Eigen::VectorXd>(coef.data(), static_cast<Eigen::Index>(coef.size()));
  return mean_abs(X, b, nullptr);
}

LockinFit::LockinFit(const PairSeries& s, int harmonics, int min_cycles) : H_(harmonics), nb_(s.n_bins) {
  if (!(harmonics >= 1 && harmonics <= 31 && harmonics % 2 == 1))
    throw ConfigError(fmt::format("lock-in harmonics {}: expected an odd number 1..31", harmonics));
  p_ = H_ + 2;
  const std::size_t np = s.num_pairs();
  if (s.v_theta.size() != np * nb_ || s.n_vectors.size() != np * nb_ || s.phase.size() != np)
    throw InternalError("LockinFit: series arrays do not match");
  if (!s.phase_known())
    throw InputError("lock-in: the drive phase of every pair is needed (the oscillation frequency is unknown)");
  const auto p = static_cast<Eigen::Index>(p_);

  // Interval means of the basis over each pair's phases.
  Eigen::MatrixXd X(static_cast<Eigen::Index>(np), p);
  for (std::size_t k = 0; k < np; ++k) {
    const double span = k < s.phase_span.size() ? s.phase_span[k] : 0.0;
    const double th = kTwoPi * s.phase[k], d = kTwoPi * span;
    const auto r = static_cast<Eigen::Index>(k);
    X(r, 0) = 1.0;
    for (int h = 1, c = 1; h <= H_; h += 2, c += 2) {
      if (d * h > 1e-9) {
        const double a = h * (th - 0.5 * d), b = h * (th + 0.5 * d), w = h * d;
        X(r, c) = (std::sin(b) - std::sin(a)) / w;
        X(r, c + 1) = (std::cos(a) - std::cos(b)) / w;
      } else {
        X(r, c) = std::cos(h * th);
        X(r, c + 1) = std::sin(h * th);
      }
    }
  }

  // Per bin: weighted least squares.
  bins_.assign(nb_, LockinBin{});
  beta_.assign(nb_ * p_, 0.0);
  ainv_.assign(nb_ * p_ * p_, 0.0);
  std::vector<double> resid(np * nb_, 0.0);
  for (std::size_t b = 0; b < nb_; ++b) {
    Eigen::MatrixXd A = Eigen::MatrixXd::Zero(p, p);
    Eigen::VectorXd rhs = Eigen::VectorXd::Zero(p);
    std::size_t m = 0;
    for (std::size_t k = 0; k < np; ++k) {
      const double w = s.n_vectors[k * nb_ + b];
      if (!(w > 0)) continue;
      ++m;
      const auto x = X.row(static_cast<Eigen::Index>(k)).transpose();
      A.selfadjointView<Eigen::Lower>().rankUpdate(x, w);
      rhs += w * s.v_theta[k * nb_ + b] * x;
    }
    bins_[b].pairs = m;
    if (m < static_cast<std::size_t>(p_) + 2) continue;
    A = A.selfadjointView<Eigen::Lower>();
    const Eigen::VectorXd d = A.diagonal().cwiseSqrt().cwiseInverse();
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(d.asDiagonal() * A * d.asDiagonal(), Eigen::EigenvaluesOnly);
    const auto& ev = es.eigenvalues();
    if (!(ev(0) > 1e-8 * ev(p - 1))) continue;
    const Eigen::MatrixXd Ainv = A.inverse();
    const Eigen::VectorXd beta = Ainv * rhs;
    bins_[b].ok = true;
    Eigen::Map<Eigen::VectorXd>(beta_.data() + b * p_, p) = beta;
    Eigen::Map<Eigen::MatrixXd>(ainv_.data() + b * p_ * p_, p, p) = Ainv;
    for (std::size_t k = 0; k < np; ++k)
      if (s.n_vectors[k * nb_ + b] > 0)
        resid[k * nb_ + b] = s.v_theta[k * nb_ + b] - X.row(static_cast<Eigen::Index>(k)).dot(beta);
  }

  // Lag-1 correlation of the standardised residuals (sqrt(w) e), pooled over bins.
  {
    double s01 = 0, s00 = 0;
    for (std::size_t b = 0; b < nb_; ++b) {
      if (!bins_[b].ok) continue;
      for (std::size_t k = 0; k < np; ++k) {
        const double w = s.n_vectors[k * nb_ + b];
        if (!(w > 0)) continue;
        const double u = std::sqrt(w) * resid[k * nb_ + b];
        s00 += u * u;
        if (k + 1 < np && s.n_vectors[(k + 1) * nb_ + b] > 0)
          s01 += u * std::sqrt(s.n_vectors[(k + 1) * nb_ + b]) * resid[(k + 1) * nb_ + b];
      }
    }
    rho_ = s00 > 0 ? s01 / s00 : 0.0;
  }

  // Clusters: whole cycles, or blocks of L consecutive pairs.
  std::vector<std::size_t> cluster(np, 0);
  std::map<int, std::size_t> cycles;
  for (std::size_t k = 0; k < np; ++k)
    if (s.cycle[k] != PairSeries::kNoCycle) cycles.emplace(s.cycle[k], 0);
  by_cycles_ = cycles.size() >= static_cast<std::size_t>(std::max(2, min_cycles)) &&
               std::none_of(s.cycle.begin(), s.cycle.end(), [](int c) { return c == PairSeries::kNoCycle; });
  if (by_cycles_) {
    std::size_t g = 0;
    for (auto& kv : cycles) kv.second = g++;
    for (std::size_t k = 0; k < np; ++k) cluster[k] = cycles[s.cycle[k]];
    G_ = cycles.size();
    L_ = 0;
  } else {
    const double r = std::clamp(rho_, 0.0, 0.95);
    const double tau = (1.0 + r) / (1.0 - r);
    L_ = static_cast<std::size_t>(std::ceil(10.0 * tau));
    // At least 8 blocks where the pairs allow it.
    L_ = std::max<std::size_t>(1, std::min(L_, np / 8));
    for (std::size_t k = 0; k < np; ++k) cluster[k] = k / L_;
    G_ = (np + L_ - 1) / L_;
  }
  score_.assign(G_ * nb_ * p_, 0.0);
  clusters_with_data_.assign(nb_, 0);
  auto& clusters_with_data = clusters_with_data_;
  {
    std::vector<char> seen(G_ * nb_, 0);
    for (std::size_t k = 0; k < np; ++k)
      for (std::size_t b = 0; b < nb_; ++b) {
        const double w = s.n_vectors[k * nb_ + b];
        if (!bins_[b].ok || !(w > 0)) continue;
        double* g = score_.data() + (cluster[k] * nb_ + b) * p_;
        const double we = w * resid[k * nb_ + b];
        for (int j = 0; j < p_; ++j) g[j] += we * X(static_cast<Eigen::Index>(k), j);
        char& sn = seen[cluster[k] * nb_ + b];
        if (!sn) {
          sn = 1;
          ++clusters_with_data[b];
        }
      }
  }

  // Covariances, amplitudes, implied mean |v| and floors.
  const Eigen::MatrixXd Xg = grid_basis(H_);
  grid_.assign(Xg.data(), Xg.data() + Xg.size());
  for (std::size_t b = 0; b < nb_; ++b) {
    LockinBin& o = bins_[b];
    if (!o.ok) continue;
    const Eigen::VectorXd beta = Eigen::Map<const Eigen::VectorXd>(beta_.data() + b * p_, p);
    const Eigen::MatrixXd Ainv = Eigen::Map<const Eigen::MatrixXd>(ainv_.data() + b * p_ * p_, p, p);
    o.in_phase = beta(1);
    o.quadrature = beta(2);
    o.amplitude = std::hypot(beta(1), beta(2));
    o.lag_deg = std::atan2(beta(2), beta(1)) * 180.0 / std::numbers::pi;
    Eigen::VectorXd grad;
    o.v_abs = mean_abs(Xg, beta, &grad);
    const std::size_t Gb = clusters_with_data[b];
    if (Gb < 2) continue;
    Eigen::MatrixXd B = Eigen::MatrixXd::Zero(p, p);
    for (std::size_t c = 0; c < G_; ++c) {
      const Eigen::Map<const Eigen::VectorXd> g(score_.data() + (c * nb_ + b) * p_, p);
      B += g * g.transpose();
    }
    const double Gd = static_cast<double>(Gb);
    const Eigen::MatrixXd V = Gd / (Gd - 1.0) * Ainv * B * Ainv;
    // Standard error of the amplitude (delta method; at zero amplitude the mean of the two).
    if (o.amplitude > 0) {
      Eigen::Vector2d u(beta(1) / o.amplitude, beta(2) / o.amplitude);
      o.amplitude_se = std::sqrt(std::max(0.0, u.dot(V.block<2, 2>(1, 1) * u)));
    } else {
      o.amplitude_se = std::sqrt(std::max(0.0, 0.5 * (V(1, 1) + V(2, 2))));
    }
    o.v_abs_se = std::sqrt(std::max(0.0, grad.dot(V * grad)));
    // Floor: E|N(0, s(theta)^2)| = sqrt(2/pi) s(theta), averaged over the cycle.
    double fl = 0;
    for (Eigen::Index i = 0; i < Xg.rows(); ++i) {
      const Eigen::VectorXd x = Xg.row(i).transpose();
      fl += std::sqrt(std::max(0.0, x.dot(V * x)));
    }
    o.v_noise = std::sqrt(2.0 / std::numbers::pi) * fl / static_cast<double>(Xg.rows());
    // Effective pairs: independent-pairs variance of a1 over the clustered one.
    double swe2 = 0;
    for (std::size_t k = 0; k < np; ++k) {
      const double w = s.n_vectors[k * nb_ + b];
      if (w > 0) swe2 += w * resid[k * nb_ + b] * resid[k * nb_ + b];
    }
    const double s2 = swe2 / static_cast<double>(o.pairs - static_cast<std::size_t>(p_));
    if (V(1, 1) > 0) o.n_eff = static_cast<double>(o.pairs) * s2 * Ainv(1, 1) / V(1, 1);
  }
}

void LockinFit::draw(std::mt19937_64& rng, std::vector<double>& v_abs) const {
  const auto p = static_cast<Eigen::Index>(p_);
  std::vector<double> eta(G_);
  for (auto& e : eta) e = (rng() >> 63) ? 1.0 : -1.0;
  const Eigen::Map<const Eigen::MatrixXd> Xg(grid_.data(), static_cast<Eigen::Index>(grid_.size() / p_), p);
  v_abs.assign(nb_, core::kUnset);
  Eigen::VectorXd delta(p);
  for (std::size_t b = 0; b < nb_; ++b) {
    if (!bins_[b].ok) continue;
    delta.setZero();
    for (std::size_t c = 0; c < G_; ++c)
      delta += eta[c] * Eigen::Map<const Eigen::VectorXd>(score_.data() + (c * nb_ + b) * p_, p);
    const std::size_t gb = clusters_with_data_[b];
    const Eigen::Map<const Eigen::VectorXd> beta(beta_.data() + b * p_, p);
    const Eigen::Map<const Eigen::MatrixXd> Ainv(ainv_.data() + b * p_ * p_, p, p);
    const double f = gb >= 2 ? std::sqrt(static_cast<double>(gb) / static_cast<double>(gb - 1)) : 1.0;
    const Eigen::VectorXd bstar = beta + f * (Ainv * delta);
    v_abs[b] = mean_abs(Xg, bstar, nullptr);
  }
}

}  // namespace shearzone::profile
