// shearzone/profile/width.hpp: the shear-zone width r_c of a radial profile.
//
// r_c is the first radius, scanning outwards from the vane, at which the mean |v|
// drops below the threshold v_c (the paper: 4e-5 m/s), with linear interpolation
// between the two bins that bracket the crossing. Bins without vectors are skipped.
// Status:
//   ok            a crossing was found;
//   never_below   |v| stays above v_c up to the last bin: r_c = R is reported;
//   below_at_vane the first bin is already below v_c: r_c = its centre is reported;
//   noise_limited v_c < 3 x the noise floor of |v| (the median of v_noise over the
//                 bins): |v| cannot fall below v_c for a physical reason, so the
//                 r_c found (reported) cannot be trusted. This status wins over
//                 the others.
// Confidence interval: percentile bootstrap of the profile's per-pair bin means
// under the grouping of profile/resample.hpp (whole cycles, or pairs with the
// phase modulation removed and the residuals an AR(1) series); a single pair gives
// no interval (NaN). Seeded: deterministic.
//
// Estimators (Estimator):
//   mean_abs  the paper's mean |v| per bin (above);
//   lockin    the mean |v_theta| implied by the phase-locked waveform of v_theta
//             (profile/lockin.hpp), whose noise floor falls like 1/sqrt(n). The same
//             scan; noise_limited when v_c < noise_factor x the lock-in floor at the
//             crossing (the larger of the two bracketing bins' floors; the last bin's
//             for never_below, the first's for below_at_vane). Interval: wild
//             bootstrap of the lock-in fit (signs flipped per cluster: cycles or
//             blocks of pairs), widened by t_(G-1) / z for G clusters;
//   auto      mean_abs, unless it is noise_limited and the profile has lock-in values:
//             then lockin. The result says which was used.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "shearzone/profile/radial_profile.hpp"

namespace shearzone::profile {

enum class WidthStatus { kOk, kNeverBelow, kBelowAtVane, kNoiseLimited };
const char* width_status_name(WidthStatus s);

enum class Estimator { kMeanAbs, kLockin, kAuto };
const char* estimator_name(Estimator e);  ///< "mean_abs", "lockin", "auto"
/// mean-abs (or mean_abs), lockin, auto; ConfigError "--estimator <name>: expected
/// mean-abs, lockin or auto" otherwise.
Estimator estimator_from_name(const std::string& name);

struct WidthOptions {
  double v_c_m_per_s = 4e-5;   ///< threshold velocity
  double noise_factor = 3.0;   ///< noise_limited when v_c < noise_factor * v_noise
  int bootstrap = 2000;        ///< resamples (0: no interval)
  double confidence = 0.95;    ///< two-sided level of the interval
  std::uint64_t seed = 1;      ///< bootstrap seed
  Estimator estimator = Estimator::kAuto;
  /// Widen the interval by the binning's bias bound b at the crossing (scan_rc's
  /// bin_bound_m), combined with the sampling half-width h of each side as a
  /// rectangular error: sqrt(h^2 + z^2 b^2 / 3). Off: the interval holds the sampling
  /// noise and the PIV's bounds (footprint, bias; when WidthInput knows them), not the
  /// binning's, as against a truth scanned from the same bins.
  bool widen_by_binning = true;
  void validate() const;
};

/// Where a bin's vectors lie: the mean and standard deviation of their radii, m, per bin
/// (empty: unknown; then each bin is taken as evenly filled about its centre).
struct VectorRadii {
  std::vector<double> mean_m, sd_m;
  bool known() const { return !mean_m.empty(); }
};

/// What the width needs from a profile (a RadialProfile, or one read back from CSV).
struct WidthInput {
  std::vector<double> r_m, v_abs;             ///< per bin (v_abs NaN where n = 0)
  std::vector<std::size_t> n_vectors;         ///< per bin (0: no data, skipped)
  std::vector<double> v_noise;                ///< per bin noise floor, m/s
  double R_m = 0;                             ///< cup radius (r_c when never below)
  PairSeries pairs;                           ///< per-pair bin means (may be empty)
  Grouping grouping = Grouping::kNone;        ///< how to resample them (kNone: no interval)
  // Lock-in values per bin (empty vectors: none; NaN in a bin: no value there).
  std::vector<double> v_abs_lockin, v_noise_lockin;
  int lockin_harmonics = 0;                   ///< H of the profile's fit (for the interval)
  VectorRadii radii;                          ///< where each bin's vectors lie (may be unknown)
  /// Radial variance of the footprint each velocity is a mean over, m^2 (0: none or
  /// unknown): for PIV, (W^2 / 12 + d^2 / 4) m_per_px^2 for a final window of W px and a
  /// texture of d px (the profile's header, velocity_footprint_var_m2).
  double footprint_var_m2 = 0;
  /// Bound of the velocities' systematic error, m/s (0: none known): for PIV,
  /// kPivBiasBoundPx m_per_px / dt (the profile's header, velocity_bias_bound_m_per_s).
  double velocity_bias_m_per_s = 0;
  bool has_lockin() const;
  /// Appends a bin (the next larger radius) to r_m, v_abs, n_vectors and v_noise.
  void add_bin(double r, double v_abs_bin, std::size_t n, double v_noise_bin);
  static WidthInput from_profile(const RadialProfile& p, double R_m);
};

/// How far a bias moves r_c: outwards and inwards, m.
struct BiasShift {
  double out_m = 0, in_m = 0;
};

struct WidthResult {
  Estimator estimator = Estimator::kMeanAbs;  ///< the one used (never kAuto)
  double rc_m = 0;
  double ci_low_m = kNoValue, ci_high_m = kNoValue;  ///< NaN: no interval
  WidthStatus status = WidthStatus::kOk;
  double v_noise_m_per_s = 0;  ///< the noise floor used for the status
  Grouping grouping = Grouping::kNone;  ///< what the bootstrap resampled
  std::size_t bootstrap_units = 0;      ///< cycles or pairs resampled (0: none)
  double rho = 0;                       ///< AR(1) lag-1 correlation (pairs groupings)
  /// r_c may read up to this much high (resolution_bound_m); the interval's low end
  /// holds it. 0: none known.
  double resolution_bound_m = 0;
  /// How far the velocities' bias bound moves r_c either way (velocity_bias_shift); the
  /// interval holds it as a rectangular error on each side.
  BiasShift velocity_bias;
};

/// The scan alone: r_c of bin means `v` (bins with n = 0 skipped), ln v interpolated
/// between the bracketing bins (linear where one is <= 0).
/// - `radii` known: between the mean radii of the two bins' vectors, each bin's ln v less
///   the mean of exp over its vectors' spread, s^2 / (2 lambda^2) (exact to second order
///   for v = A exp(-r / lambda)); `bin_bound_m` receives the next order's size,
///   max(s^4) / (20 lambda^3).
/// - unknown: between the bin centres `r`, less lambda ln(sinh(x)/x) with x = D / (2 lambda)
///   for neighbouring bins D apart (radii spread evenly); `bin_bound_m` receives that
///   correction as the bound of its error (a grid fills a bin unevenly).
/// `bin_bound_m` is 0 where no correction applies. `lambda_m` (optional) receives the
/// decay length between the two bins (0 where r_c was not interpolated in ln v).
double scan_rc(const std::vector<double>& r, const std::vector<double>& v,
               const std::vector<std::size_t>& n, double v_c, double R_m, WidthStatus& status,
               double* bin_bound_m = nullptr, const VectorRadii& radii = {}, double* lambda_m = nullptr);

/// The PIV's displacement bias, px per pair, that width's intervals allow for: uniform
/// shifts of 0-7 px read within 0.01 px (tests/piv/test_piv.cpp); the v_theta of 12 px
/// beads moving 0.05-0.2 px per pair read 0.0035 px low (docs/profile-width.md).
inline constexpr double kPivBiasBoundPx = 0.01;

/// The variance of the footprint one PIV velocity is a mean over, m^2: a final window of
/// W px (variance W^2 / 12 about its centre along any direction) and a texture of d px
/// that moves with its bead's centre, up to d / 2 away (variance <= d^2 / 4).
inline double piv_footprint_var_m2(double final_window_px, double texture_px, double m_per_px) {
  const double W = final_window_px, d = texture_px;
  return (W * W / 12.0 + d * d / 4.0) * m_per_px * m_per_px;
}
/// The bound of a PIV velocity's systematic error, m/s: kPivBiasBoundPx per pair over dt.
inline double piv_velocity_bias_bound(double m_per_px, double dt_s) { return kPivBiasBoundPx * m_per_px / dt_s; }

/// How far a velocity bias of at most `bias_m_per_s` moves r_c where v crosses v_c over
/// a decay of length lambda: lambda ln(1 + e) outwards and -lambda ln(1 - e) inwards,
/// e = bias / v_c (inwards: down to the vane, r_c - r_first, when e >= 1). 0 where either
/// is unknown.
BiasShift velocity_bias_shift(double bias_m_per_s, double v_c, double lambda_m, double rc_m, double r_first_m);

/// How far r_c may read high because each velocity is a mean over a footprint of radial
/// variance `footprint_var_m2` (a PIV window and the texture it follows): an exponential
/// decay of length lambda averaged so reads exp(var / (2 lambda^2)) high to second order,
/// r_c var / (2 lambda) out. 0 where either is unknown.
double resolution_bound_m(double footprint_var_m2, double lambda_m);

/// r_c, its bootstrap interval and its status.
WidthResult shear_zone_width(const WidthInput& in, const WidthOptions& options);

}  // namespace shearzone::profile
