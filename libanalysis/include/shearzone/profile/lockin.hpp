// shearzone/profile/lockin.hpp: phase-locked (lock-in) velocity amplitudes per radius.
//
// Why: the plain mean |v| of a bin cannot fall below the noise floor of |v|
// (sigma sqrt(pi/2) for Gaussian PIV noise of sigma per component), however many
// pairs are averaged, because noise piles up in a magnitude. The signed azimuthal
// velocity v_theta, locked to the drive, averages its noise away: its amplitude at the
// drive frequency has a floor that falls like 1/sqrt(n).
//
// Model, per radial bin: the pair means y_k of v_theta (pair k spans the drive phases
// theta_a..theta_b, theta = 2 pi f (t - t0), the vane angle phi = phi0 sin theta, so the
// vane's angular velocity is in phase with cos theta) follow
//     v_theta(theta) = c0 + sum_{h = 1, 3, ..., H} a_h cos(h theta) + b_h sin(h theta),
// averaged over the pair's interval (a PIV pair measures the mean velocity between its
// frames; the regressors are the interval means of cos and sin, so the waveform is the
// instantaneous one). Weighted least squares, weights = the pair's vector count in the
// bin (all valid vectors of all pairs count equally).
//
// Reported per bin:
//   amplitude  sqrt(a1^2 + b1^2) at the drive frequency, and lag = atan2(b1, a1) (> 0:
//              the beads' velocity peaks after the vane's);
//   in-phase   a1, the part in phase with the drive's velocity: a drive phase error
//              eps multiplies it by cos(eps) (and shifts the lag by eps), while the
//              amplitude and the implied mean |v| do not depend on eps;
//   v_abs      the mean |v_theta| the fitted waveform implies, mean over a cycle of
//              |c0 + sum ...| (for a pure sinusoid (2/pi) x amplitude), with its
//              standard error by the delta method;
//   v_noise    the floor of that estimate: its mean value when the true waveform is
//              zero, sqrt(2/pi) x the cycle mean of the waveform's standard error. It
//              falls like 1/sqrt(n).
// Standard errors: a cluster-robust (sandwich) covariance of the coefficients, the
// clusters being whole oscillation cycles when at least `min_cycles` hold data (cycles
// are far enough apart to be independent; any correlation within a cycle, in time or
// between the vectors of a pair, is inside a cluster), otherwise blocks of L
// consecutive pairs, L = ceil(10 tau), tau = (1 + rho)/(1 - rho) the integrated
// correlation time of AR(1) residuals of lag-1 correlation rho (>= 0), measured on the
// pair residuals, and at most pairs / 8 (at least 8 blocks). The covariance carries
// the factor G/(G - 1) for G clusters. Measured coverage of the 95 % r_c interval
// (tests/profile/test_lockin.cpp, 400 seeds): 6 cycles of independent pairs (blocks)
// 93.75 %; 12 cycles with AR(1) noise rho = 0.5 (cycles) 93.5 %; 6 cycles with
// rho = 0.5 (blocks) 92.25 %, rho = 0.8 91.5 %: strong correlation over few cycles
// is the weak case (blocks shorter than 10 tau where the pairs do not allow 8 of them).
// n_eff = pairs x (variance of a1 if the pairs were independent) / (the clustered
// one): the number of independent pairs the data are worth.
// Bins whose pairs do not cover the cycle well enough to separate the harmonics
// (normalised normal matrix with a condition number above 1e8, or fewer than p + 2
// pairs) carry no lock-in value.
#pragma once

#include <cstddef>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "shearzone/core/unset.hpp"
#include "shearzone/profile/resample.hpp"

namespace shearzone::profile {

struct LockinBin {
  bool ok = false;                          ///< a value exists
  double amplitude = core::kUnset;          ///< sqrt(a1^2 + b1^2), m/s
  double amplitude_se = core::kUnset;       ///< m/s
  double lag_deg = core::kUnset;            ///< atan2(b1, a1), degrees in (-180, 180]
  double in_phase = core::kUnset;           ///< a1, m/s
  double quadrature = core::kUnset;         ///< b1, m/s
  double v_abs = core::kUnset;              ///< implied mean |v_theta|, m/s
  double v_abs_se = core::kUnset;           ///< m/s
  double v_noise = core::kUnset;            ///< floor of v_abs, m/s
  double n_eff = core::kUnset;              ///< effective independent pairs
  std::size_t pairs = 0;                    ///< pairs with vectors in the bin
};

/// Mean over a cycle of |c0 + sum_h a_h cos(h theta) + b_h sin(h theta)| for the
/// coefficient vector (c0, a1, b1, a3, b3, ...), on a uniform grid of theta.
double waveform_mean_abs(const std::vector<double>& coef);

class LockinFit {
 public:
  /// harmonics: the highest odd harmonic H (1, 3, 5, ... <= 31). Throws ConfigError
  /// for an even or out-of-range H, InputError when the phases are unknown.
  LockinFit(const PairSeries& series, int harmonics, int min_cycles = kMinBootstrapCycles);
  const std::vector<LockinBin>& bins() const { return bins_; }
  int harmonics() const { return H_; }
  /// "cycles" or "pair_blocks".
  const char* cluster_kind() const { return by_cycles_ ? "cycles" : "pair_blocks"; }
  std::size_t clusters() const { return G_; }
  std::size_t block_pairs() const { return L_; }  ///< L (pair_blocks), 0 for cycles
  double rho() const { return rho_; }             ///< lag-1 correlation of the pair residuals
  /// A wild-bootstrap replicate of the implied mean |v| per bin (NaN where no value):
  /// each cluster's residuals flip sign together (Rademacher), which reproduces the
  /// clustered covariance; all bins of a cluster share the sign (their correlation kept).
  void draw(std::mt19937_64& rng, std::vector<double>& v_abs) const;

 private:
  int H_ = 1, p_ = 3;
  bool by_cycles_ = false;
  std::size_t nb_ = 0, G_ = 0, L_ = 0;
  double rho_ = 0;
  std::vector<LockinBin> bins_;
  std::vector<double> beta_;    // [bin * p]
  std::vector<double> ainv_;    // [bin * p * p], A^-1
  std::vector<double> score_;   // [cluster * nb * p], sum of w x e over the cluster
  std::vector<double> grid_;    // basis on the phase grid, column-major [M x p]
  std::vector<std::size_t> clusters_with_data_;  // per bin
};

}  // namespace shearzone::profile
