// shearzone/core/sine_fit.hpp: the drive's sinusoid, fitted to a sampled record (the
// LAOS drive, a vane's angle log, the angles found in the frames). One fit for every
// stage, so that the vane's phase means the same wherever it was found.
//
//   x(t) ≈ A sin ω(t − t_ref) + B cos ω(t − t_ref) + C [+ D (t − t_ref)]
//        = x0 sin(ω t + ψ) + C [+ D (t − t_ref)],  x0 = hypot(A, B),
//          ψ = atan2(B, A) − ω t_ref
//
// fit_sine_at holds ω fixed (linear least squares); fit_sine finds ω as well (IEEE-1057's
// four-parameter fit: a golden-section search of the residual over the spectral main
// lobe about a guess, then Gauss-Newton in all parameters).
#pragma once

#include <string>
#include <vector>

namespace shearzone::core {

/// The linear fit at fixed ω about t_ref, and its residual sum of squares.
struct SineAt {
  double A = 0, B = 0, C = 0, D = 0, rss = 0;
};
/// t and x of one length (>= 3, or 4 with `drift`); D = 0 without `drift`.
SineAt fit_sine_at(const std::vector<double>& t, const std::vector<double>& x, double omega_rad_per_s,
                   double t_ref_s, bool drift);

struct SineFit {
  double omega = 0;        ///< rad/s
  double x0 = 0;           ///< amplitude (> 0)
  double psi = 0;          ///< phase at t = 0, rad: x0 sin(ω t + ψ)
  double offset = 0;       ///< C, at the middle of the record
  double rms = 0;          ///< of the residual
  double drift_per_s = 0;  ///< D of the drift term (0 without `drift`), t_ref the record's middle
};
/// The sine and its frequency, fitted to (t, x) (t increasing, n >= 4). `omega_guess`
/// NaN: from the record's crossings of its mid level (a Schmitt trigger at 2 % of the
/// half range), which needs one whole cycle: InputError starting with `context`
/// otherwise. `drift`: a fifth parameter, a linear drift about the record's middle (a
/// creeping angle under torque control would otherwise bias ψ and x0).
SineFit fit_sine(const std::vector<double>& t, const std::vector<double>& x, double omega_guess,
                 const std::string& context, bool drift = false);

}  // namespace shearzone::core
