#include "shearzone/profile/resample.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <set>

#include <Eigen/Dense>
#include <fmt/format.h>

#include "shearzone/core/enum_names.hpp"
#include "shearzone/core/error.hpp"
#include "shearzone/core/unset.hpp"

namespace shearzone::profile {

const char* grouping_name(Grouping g) {
  switch (g) {
    case Grouping::kCycles: return "cycles";
    case Grouping::kPairsPhaseDetrended: return "pairs_phase_detrended";
    case Grouping::kPairs: return "pairs";
    case Grouping::kNone: return "none";
  }
  return "?";
}

bool parse_grouping(const std::string& name, Grouping& g) {
  const auto c = core::enum_named(
      name, {Grouping::kCycles, Grouping::kPairsPhaseDetrended, Grouping::kPairs, Grouping::kNone}, grouping_name);
  if (c) g = *c;
  return c.has_value();
}

std::size_t PairSeries::add_pair(int c, double ph, double span) {
  cycle.push_back(c);
  phase.push_back(ph);
  phase_span.push_back(span);
  v_abs.resize(v_abs.size() + n_bins, 0.0);
  v_theta.resize(v_theta.size() + n_bins, 0.0);
  n_vectors.resize(n_vectors.size() + n_bins, 0.0);
  return cycle.size() - 1;
}

std::size_t PairSeries::num_cycles() const {
  std::set<int> cycles;
  for (std::size_t k = 0; k < num_pairs(); ++k) {
    if (cycle[k] == kNoCycle) continue;
    for (std::size_t b = 0; b < n_bins; ++b)
      if (n_vectors[k * n_bins + b] > 0) {
        cycles.insert(cycle[k]);
        break;
      }
  }
  return cycles.size();
}

bool PairSeries::phase_known() const {
  return num_pairs() > 0 && std::all_of(phase.begin(), phase.end(), [](double p) { return std::isfinite(p); });
}

Grouping choose_grouping(const PairSeries& s, Grouping requested, int min_cycles) {
  const std::size_t cycles = s.num_cycles();
  if (requested == Grouping::kCycles) {
    if (cycles < 2)
      throw ConfigError(fmt::format("--groups cycles: the selection holds {} oscillation cycle{}; "
                                    "resampling needs at least 2 (use --groups auto or pairs)",
                                    cycles, cycles == 1 ? "" : "s"));
    return Grouping::kCycles;
  }
  if (s.num_pairs() < 2) return Grouping::kNone;
  // requested: kNone = automatic; a pairs kind = pairs (detrended when possible).
  if (requested == Grouping::kNone && cycles >= static_cast<std::size_t>(min_cycles))
    return Grouping::kCycles;
  // Detrending needs enough pairs for a phase fit with residual degrees of freedom.
  constexpr std::size_t kMinPairsForPhaseFit = 8;
  if (s.phase_known() && s.num_pairs() >= kMinPairsForPhaseFit) return Grouping::kPairsPhaseDetrended;
  return Grouping::kPairs;
}

namespace {

/// Harmonics of the phase fit for m pairs: at most 8, and leaving at least
/// max(6, m/2) residual degrees of freedom.
int harmonics_for(std::size_t m) {
  const double keep = std::max(6.0, 0.5 * static_cast<double>(m));
  const double k = std::floor((static_cast<double>(m) - 1.0 - keep) / 2.0);
  return static_cast<int>(std::clamp(k, 0.0, 8.0));
}

/// Orthonormal basis of the column space of A (thin SVD, rank-revealing: a narrow
/// phase range, where the harmonics are nearly collinear, stays well defined).
Eigen::MatrixXd orthonormal_basis(const Eigen::MatrixXd& A) {
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeThinU);
  const auto& sv = svd.singularValues();
  const double tol =
      sv.size() ? sv(0) * 1e-10 * static_cast<double>(std::max(A.rows(), A.cols())) : 0.0;
  Eigen::Index rank = 0;
  while (rank < sv.size() && sv(rank) > tol) ++rank;
  return svd.matrixU().leftCols(rank);
}

}  // namespace

BinMeanBootstrap::BinMeanBootstrap(const PairSeries& s, Grouping g) : g_(g), nb_(s.n_bins) {
  const std::size_t np = s.num_pairs();
  if (s.v_abs.size() != np * nb_ || s.n_vectors.size() != np * nb_ || s.phase.size() != np)
    throw InternalError("BinMeanBootstrap: series arrays do not match");
  mean_.assign(nb_, core::kUnset);
  count_.assign(nb_, 0.0);
  std::vector<double> sum(nb_, 0.0);
  for (std::size_t k = 0; k < np; ++k)
    for (std::size_t b = 0; b < nb_; ++b) {
      const double n = s.n_vectors[k * nb_ + b];
      sum[b] += s.v_abs[k * nb_ + b] * n;
      count_[b] += n;
    }
  for (std::size_t b = 0; b < nb_; ++b)
    if (count_[b] > 0) mean_[b] = sum[b] / count_[b];
  if (g_ == Grouping::kNone) return;

  if (g_ == Grouping::kCycles) {
    std::map<int, std::size_t> unit_of;
    for (std::size_t k = 0; k < np; ++k)
      if (s.cycle[k] != PairSeries::kNoCycle) unit_of.emplace(s.cycle[k], 0);
    std::size_t u = 0;
    for (auto& kv : unit_of) kv.second = u++;
    units_ = unit_of.size();
    unit_s_.assign(units_ * nb_, 0.0);
    unit_n_.assign(units_ * nb_, 0.0);
    for (std::size_t k = 0; k < np; ++k) {
      if (s.cycle[k] == PairSeries::kNoCycle) continue;
      const std::size_t uk = unit_of[s.cycle[k]];
      for (std::size_t b = 0; b < nb_; ++b) {
        const double n = s.n_vectors[k * nb_ + b];
        unit_s_[uk * nb_ + b] += s.v_abs[k * nb_ + b] * n;
        unit_n_[uk * nb_ + b] += n;
      }
    }
    return;
  }

  units_ = np;
  // Per bin: weighted least squares on a Fourier basis in the phase (only the mean
  // when the phase is unknown); fitted values and residuals.
  const bool phase_fit = g_ == Grouping::kPairsPhaseDetrended;
  fit_.assign(np * nb_, 0.0);
  resid_.assign(np * nb_, 0.0);
  unit_n_ = s.n_vectors;
  const int K_full = phase_fit ? harmonics_for(np) : 0;
  // Row r of M: w (1, cos 2 pi h phase_k, sin 2 pi h phase_k, h = 1..K).
  auto design_row = [&](Eigen::MatrixXd& M, Eigen::Index r, std::size_t k, int K, double w) {
    M(r, 0) = w;
    for (int h = 1; h <= K; ++h) {
      const double a = 2.0 * std::numbers::pi * h * s.phase[k];
      M(r, 2 * h - 1) = w * std::cos(a);
      M(r, 2 * h) = w * std::sin(a);
    }
  };
  for (std::size_t b = 0; b < nb_; ++b) {
    std::vector<std::size_t> rows;
    for (std::size_t k = 0; k < np; ++k)
      if (s.n_vectors[k * nb_ + b] > 0) rows.push_back(k);
    const std::size_t m = rows.size();
    if (m == 0) continue;
    const int K = phase_fit ? harmonics_for(m) : 0;
    harmonics_ = std::max(harmonics_, K);
    const Eigen::Index p = 1 + 2 * K;
    Eigen::MatrixXd A(static_cast<Eigen::Index>(m), p);
    Eigen::VectorXd y(static_cast<Eigen::Index>(m)), sw(static_cast<Eigen::Index>(m));
    for (std::size_t i = 0; i < m; ++i) {
      const std::size_t k = rows[i];
      const auto ii = static_cast<Eigen::Index>(i);
      sw(ii) = std::sqrt(s.n_vectors[k * nb_ + b]);
      y(ii) = sw(ii) * s.v_abs[k * nb_ + b];
      design_row(A, ii, k, K, sw(ii));
    }
    const Eigen::MatrixXd U = orthonormal_basis(A);
    const Eigen::VectorXd yhat = U * (U.transpose() * y);
    for (std::size_t i = 0; i < m; ++i) {
      const std::size_t k = rows[i];
      const auto ii = static_cast<Eigen::Index>(i);
      fit_[k * nb_ + b] = yhat(ii) / sw(ii);
      resid_[k * nb_ + b] = (y(ii) - yhat(ii)) / sw(ii);
    }
  }

  // AR(1) model of the residuals, the fit's distortion accounted for: with
  // M = I - H (H the hat matrix of the unweighted design over all pairs) and
  // R(rho) the AR(1) correlation, E[sum e_k^2] = sigma^2 tr(M R M) and
  // E[sum e_k e_(k+1)] = sigma^2 sum_k (M R M)_(k,k+1). rho solves the ratio of the
  // pooled sums over the bins that hold data in every pair.
  std::vector<std::size_t> full_bins;
  for (std::size_t b = 0; b < nb_; ++b) {
    bool full = true;
    for (std::size_t k = 0; k < np && full; ++k) full = s.n_vectors[k * nb_ + b] > 0;
    if (full) full_bins.push_back(b);
  }
  Eigen::MatrixXd A(static_cast<Eigen::Index>(np), 1 + 2 * K_full);
  for (std::size_t k = 0; k < np; ++k) {
    design_row(A, static_cast<Eigen::Index>(k), k, K_full, 1.0);
  }
  const Eigen::MatrixXd U = orthonormal_basis(A);
  auto expected = [&](double rho, double& lag0, double& lag1) {
    // R U by the AR(1) recursion: (R U)_i = f_i + g_i - U_i.
    const Eigen::Index n = U.rows(), p = U.cols();
    Eigen::MatrixXd f = U, bwd = U;
    for (Eigen::Index i = 1; i < n; ++i) f.row(i) += rho * f.row(i - 1);
    for (Eigen::Index i = n - 2; i >= 0; --i) bwd.row(i) += rho * bwd.row(i + 1);
    const Eigen::MatrixXd RU = f + bwd - U;
    const Eigen::MatrixXd C = U.transpose() * RU;  // U' R U (p x p)
    lag0 = static_cast<double>(n) - C.trace();
    lag1 = 0;
    for (Eigen::Index k = 0; k + 1 < n; ++k) {
      // (M R M)_(k,k+1) = R_(k,k+1) - U_k (RU)_(k+1)' - (RU)_k U_(k+1)' + U_k C U_(k+1)'
      lag1 += rho - U.row(k).dot(RU.row(k + 1)) - RU.row(k).dot(U.row(k + 1)) +
              (U.row(k) * C * U.row(k + 1).transpose())(0, 0);
    }
    (void)p;
  };
  double ss0 = 0, ss1 = 0;
  for (std::size_t b : full_bins)
    for (std::size_t k = 0; k < np; ++k) {
      const double e = resid_[k * nb_ + b];
      ss0 += e * e;
      if (k + 1 < np) ss1 += e * resid_[(k + 1) * nb_ + b];
    }
  rho_ = 0;
  if (ss0 > 0 && np >= 4) {
    const double target = ss1 / ss0;
    double lo = -0.9, hi = 0.95, l0 = 0, l1 = 0;
    expected(lo, l0, l1);
    const double r_lo = l1 / l0;
    expected(hi, l0, l1);
    const double r_hi = l1 / l0;
    if (target <= r_lo) rho_ = lo;
    else if (target >= r_hi) rho_ = hi;
    else {
      for (int it = 0; it < 50; ++it) {
        const double mid = 0.5 * (lo + hi);
        expected(mid, l0, l1);
        (l1 / l0 < target ? lo : hi) = mid;
      }
      rho_ = 0.5 * (lo + hi);
    }
  }
  // Innovations: pre-whitened residuals, scaled per bin so that the AR(1) process
  // they drive has the variance sigma_b^2 that the residuals imply.
  double lag0 = 0, lag1 = 0;
  expected(rho_, lag0, lag1);
  const double df = std::max(1.0, lag0);  // = tr(M R M)
  innov_.assign(np * nb_, 0.0);
  const double c = std::sqrt(1.0 - rho_ * rho_);
  for (std::size_t b = 0; b < nb_; ++b) {
    double ss = 0;
    std::size_t m = 0;
    for (std::size_t k = 0; k < np; ++k)
      if (s.n_vectors[k * nb_ + b] > 0) {
        ss += resid_[k * nb_ + b] * resid_[k * nb_ + b];
        ++m;
      }
    if (m < 2) continue;
    const double sigma2 = ss / (df * static_cast<double>(m) / static_cast<double>(np));
    double ws = 0;
    for (std::size_t k = 0; k < np; ++k) {
      const double e = resid_[k * nb_ + b];
      const double prev = k > 0 ? resid_[(k - 1) * nb_ + b] : 0.0;
      const double w = k > 0 ? e - rho_ * prev : e * c;
      innov_[k * nb_ + b] = w;
      ws += w * w;
    }
    const double scale = ws > 0 ? std::sqrt(sigma2 * (1 - rho_ * rho_) * static_cast<double>(np) / ws) : 0.0;
    for (std::size_t k = 0; k < np; ++k) innov_[k * nb_ + b] *= scale;
  }
}

void BinMeanBootstrap::draw(std::mt19937_64& rng, std::vector<double>& v, std::vector<double>& n) const {
  v.assign(nb_, core::kUnset);
  n.assign(nb_, 0.0);
  if (g_ == Grouping::kNone) {
    v = mean_;
    n = count_;
    return;
  }
  std::vector<double> sum(nb_, 0.0);
  if (g_ != Grouping::kCycles) {
    // Pair k keeps its fitted value and its count; the noise is an AR(1) series
    // driven by innovations drawn (as whole pairs, all bins together) from the data.
    std::uniform_int_distribution<std::size_t> pick(0, units_ - 1);
    std::vector<double> e(nb_, 0.0);
    const double c = std::sqrt(1.0 - rho_ * rho_);
    for (std::size_t k = 0; k < units_; ++k) {
      const std::size_t j = pick(rng);
      for (std::size_t b = 0; b < nb_; ++b) {
        const double w = innov_[j * nb_ + b];
        e[b] = k == 0 ? w / c : rho_ * e[b] + w;
        const double nk = unit_n_[k * nb_ + b];
        if (nk == 0) continue;
        sum[b] += nk * (fit_[k * nb_ + b] + e[b]);
        n[b] += nk;
      }
    }
    for (std::size_t b = 0; b < nb_; ++b)
      if (n[b] > 0) v[b] = sum[b] / n[b];
    return;
  }
  // Cycles: plain resampling with replacement.
  std::uniform_int_distribution<std::size_t> pick(0, units_ - 1);
  for (std::size_t k = 0; k < units_; ++k) {
    const std::size_t u = pick(rng);
    for (std::size_t b = 0; b < nb_; ++b) {
      sum[b] += unit_s_[u * nb_ + b];
      n[b] += unit_n_[u * nb_ + b];
    }
  }
  for (std::size_t b = 0; b < nb_; ++b)
    if (n[b] > 0) v[b] = sum[b] / n[b];
}

std::vector<double> BinMeanBootstrap::standard_errors(int replicates, std::uint64_t seed) const {
  std::vector<double> se(nb_, core::kUnset);
  if (g_ == Grouping::kNone || replicates < 2) return se;
  std::mt19937_64 rng(seed);
  std::vector<double> s(nb_, 0.0), s2(nb_, 0.0), v, n;
  std::vector<int> used(nb_, 0);
  for (int r = 0; r < replicates; ++r) {
    draw(rng, v, n);
    for (std::size_t b = 0; b < nb_; ++b)
      if (std::isfinite(v[b])) {
        s[b] += v[b];
        s2[b] += v[b] * v[b];
        ++used[b];
      }
  }
  for (std::size_t b = 0; b < nb_; ++b)
    if (used[b] >= 2) {
      const double m = s[b] / used[b];
      se[b] = std::sqrt(std::max(0.0, (s2[b] / used[b] - m * m) * used[b] / (used[b] - 1.0)));
    }
  return se;
}

}  // namespace shearzone::profile
