// shearzone/laos/harmonics.hpp: harmonic (Fourier) analysis of an oscillatory
// response by quadrature-weighted linear least squares in the drive phase θ, and
// the quantities derived from the harmonics (docs/laos.md, "Estimator"; the Chebyshev
// measures of Ewoldt, Hosoi & McKinley, J. Rheol. 52, 1427 (2008)).
//
// Model. The drive is x = x0 sin θ (x: vane angle φ in rad, or strain), the
// response r (torque in N m, or stress in Pa) is fitted as
//     r(θ) = x0 Σ_{n=1..M} [K'_n sin nθ + K''_n cos nθ] + c0 + c1 (θ − θ_mid)/(2π)
// (c0: offset; c1: linear drift per cycle, optional). K'_n, K''_n have the units of
// r/x (N m/rad); with x = strain and r = stress they are G'_n, G''_n in Pa.
// Rows are weighted by their trapezoid share of θ, so that the estimate equals the
// Fourier projection on non-uniform samples (Δφ-triggered loggers). Standard errors
// assume white noise of constant variance per sample: the sandwich covariance
// A⁻¹ Xᵀ W² X A⁻¹ σ̂² (A = XᵀWX), with σ̂² the weighted mean squared residual times
// n/(n − p). With equal weights this is the usual σ̂² (XᵀX)⁻¹.
//
// Sign convention (README, Conventions): φ > 0 counter-clockwise as the camera
// sees it, τ > 0 when the motor drives towards +φ; an elastic sample has K'_1 > 0.
#pragma once

#include <cstddef>
#include <limits>
#include <vector>

#include "shearzone/core/unset.hpp"

namespace shearzone::laos {

struct HarmonicFitOptions {
  int max_harmonic = 9;  ///< M: sin nθ and cos nθ for n = 1..M (odd and even)
  bool drift = true;     ///< fit the linear-drift column c1
};

struct HarmonicFit {
  int M = 0;
  double amplitude = 0;               ///< x0 used to scale the coefficients
  std::vector<double> Kp, Kpp;        ///< K'_n, K''_n, index n = 0..M (index 0 unused, 0)
  std::vector<double> Kp_se, Kpp_se;  ///< standard errors, same indexing
  double offset = 0, offset_se = 0;   ///< c0, response units
  double drift_per_cycle = 0, drift_se = 0;  ///< c1, response units per 2π of θ
  double theta_mid = 0;               ///< θ at which the drift column is zero
  double sigma = 0;                   ///< σ̂: residual standard deviation per sample
  std::size_t samples = 0;            ///< rows with positive weight
  /// Response of the fitted model at θ (harmonics, offset and drift).
  double evaluate(double theta) const;
  /// Harmonic part only, odd n: elastic x0 Σ K'_n sin nθ (sin_part) or viscous
  /// x0 Σ K''_n cos nθ (cos part).
  double odd_sin_part(double theta) const;
  double odd_cos_part(double theta) const;
};

/// Trapezoid quadrature weights of samples θ_i (non-decreasing) for ∫_a^b f dθ, with
/// f linearly interpolated between samples: samples outside [a, b] get 0 except the
/// neighbours of a and b, which carry the interpolated end pieces. Requires
/// θ_0 ≤ a < b ≤ θ_last. Adds into `w` (sized like theta).
void add_trapezoid_weights(const std::vector<double>& theta, double a, double b,
                           std::vector<double>& w);

/// Weighted least-squares fit; rows with weight 0 are ignored. Throws InputError if
/// fewer than 2M + 3 rows have positive weight or amplitude <= 0.
HarmonicFit fit_harmonics(const std::vector<double>& theta, const std::vector<double>& response,
                          const std::vector<double>& weights, double amplitude,
                          const HarmonicFitOptions& options);

/// Quantities derived from the harmonics (odd n only for the Chebyshev/Ewoldt ones).
struct Measures {
  int M = 0;
  double omega = core::kUnset;          ///< rad/s (NaN: unknown, rate measures NaN)
  double K1p = 0, K1pp = 0, K1p_se = 0, K1pp_se = 0;
  double tan_delta = 0;                 ///< K''_1/K'_1
  std::vector<double> I_over_I1;        ///< |K*_n|/|K*_1|, index n
  std::vector<double> Phi;              ///< Φ_n = δ_n − n δ_1 mod 2π in [0, 2π), δ = atan2(K'', K')
  std::vector<double> e, v;             ///< Chebyshev e_n = K'_n(−1)^((n−1)/2), v_n = K''_n/ω (odd n; 0 for even)
  double K_M = 0, K_L = 0;              ///< Σ n K'_n, Σ e_n (odd n ≤ M)
  /// (1/ω)Σ n K''_n (−1)^((n−1)/2), (1/ω)Σ K''_n
  double eta_M = core::kUnset, eta_L = core::kUnset;
  double S = 0, T = 0;                  ///< (K_L − K_M)/K_L, (η_L − η_M)/η_L (T needs no ω)
  double e3_over_e1 = core::kUnset, v3_over_v1 = core::kUnset;
  double I3_over_I1 = core::kUnset, I2_over_I1 = core::kUnset;
};
Measures derive_measures(const HarmonicFit& fit, double omega_rad_per_s);

/// Loop area ∮ r dx of the closed polygon through the samples (trapezoid rule; the
/// closing segment from the last sample to the first is included). E_d in J when x
/// is in rad and r in N m.
double loop_area(const std::vector<double>& x, const std::vector<double>& r);

}  // namespace shearzone::laos
