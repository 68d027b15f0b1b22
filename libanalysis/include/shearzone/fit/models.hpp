// shearzone/fit/models.hpp: the toolkit's curve models and their fits with
// automatic starting values and a per-fit status.
//
// Models (templated functors, usable with double and Dual<N>):
//   ErfTransition  r(x) = rc0 + (rcinf − rc0)·½(1 + erf((x − phi_c)/W)), W > 0
//                  (W is fitted as ln W; its SE comes from the delta method).
//                  W is √2 times the σ of the equivalent Gaussian: ½(1+erf(x/W)) is
//                  0.1587 and 0.8413 at x = ∓W/√2, so the 16–84 % width is √2·W.
//   PowerLaw       y = A·x^k (x > 0)
//   Line           y = a + b·x (the log–log fit of a power law)
//
// Degeneracies are a status, never invented numbers (see FitStatus).
#pragma once

#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "shearzone/fit/least_squares.hpp"

namespace shearzone::fit {

struct ErfTransition {
  static constexpr int kParams = 4;  // rc0, rcinf, phi_c, W
  template <class T>
  T operator()(const T* p, double x) const {
    using std::erf;
    return p[0] + (p[1] - p[0]) * (0.5 * (1.0 + erf((x - p[2]) / p[3])));
  }
};

struct PowerLaw {
  static constexpr int kParams = 2;  // A, k
  template <class T>
  T operator()(const T* p, double x) const {
    using std::pow;
    return p[0] * pow(x, p[1]);
  }
};

struct Line {
  static constexpr int kParams = 2;  // a, b
  template <class T>
  T operator()(const T* p, double x) const {
    return p[0] + p[1] * x;
  }
};

/// The outcome of a curve fit. Only kOk is usable downstream.
enum class FitStatus {
  kOk,
  kTooFewPoints,            ///< fewer points than parameters (+1 when σ is estimated)
  kFlatData,                ///< y does not vary: nothing to fit
  kTransitionOutsideRange,  ///< erf: fitted phi_c outside [min x, max x]
  kTransitionUnresolved,    ///< erf: fewer than 2 points within phi_c +- W (W not measured)
  kNonPositiveValues,       ///< power law: x <= 0, or y <= 0 in log space
  kNoConvergence,           ///< the solver failed or did not converge
  kSingularCovariance,      ///< rank-deficient Jacobian: no standard errors
};
/// "ok", "too_few_points", "flat_data", "transition_outside_range",
/// "transition_unresolved", "nonpositive_values", "no_convergence", "singular_covariance".
const char* status_name(FitStatus s);

struct CurveFit {
  FitStatus status = FitStatus::kNoConvergence;
  std::string message;        ///< why, for a status other than ok
  bool has_result = false;    ///< `result` holds a solver run (values may be shown)
  FitResult result;
  bool usable() const { return status == FitStatus::kOk; }
};

/// Starting values (rc0, rcinf, phi_c, W) of the erf transition: plateaus from the
/// means of the first and last quarter of the points (at most 3 each, sorted by x),
/// phi_c from the 50 % crossing and W = √2·(x84 − x16)/2 from the 16 % and 84 %
/// crossings of the normalised data (linear interpolation); fallback W = range/10.
std::array<double, 4> erf_start(const std::vector<double>& x, const std::vector<double>& y);

/// Fits the erf transition. `sigma` empty: unit weights.
CurveFit fit_erf(const std::vector<double>& x, const std::vector<double>& y,
                 const std::vector<double>& sigma, const FitOptions& options = {});

enum class PowerSpace { kLinear, kLog };
PowerSpace parse_power_space(const std::string& name);

/// Fits y = A x^k: weighted NLS in linear space (start from the log–log line), or a
/// straight line ln y = ln A + k ln x with σ_log = σ/y (kLog; A fitted as ln A).
CurveFit fit_power(const std::vector<double>& x, const std::vector<double>& y,
                   const std::vector<double>& sigma, PowerSpace space,
                   const FitOptions& options = {});

/// y − y(x0) for the power law of a difference (e.g. rc∞(N) − rc∞(1) ~ N^β). The
/// points with |x − x0| <= rtol·|x0| are removed; y(x0) is their (σ-weighted) mean
/// and its σ is added in quadrature to every remaining σ (the correlation this
/// introduces between points is ignored). Returns false (and leaves the data
/// alone) when no point is at x0.
bool subtract_at(std::vector<double>& x, std::vector<double>& y, std::vector<double>& sigma,
                 double x0, double rtol, double* y0 = nullptr, double* sigma0 = nullptr);

}  // namespace shearzone::fit
