// shearzone/fit/least_squares.hpp: the one nonlinear least-squares entry point.
//
// Every fit of the toolkit (the CLI's erf and power-law fits, the global erf
// collapse, the NIST StRD checks in the tests) goes through solve(): a Problem
// gives, for each data point i, the model value f_i(p) and its exact gradient;
// solve() minimises ½ Σ ρ(r_i²) with r_i = (y_i − f_i(p))/σ_i (σ_i = 1 when no
// σ is given; ρ the identity, Huber or Cauchy) and reports the estimate with its
// uncertainty. Curve models are templated functors (models.hpp); curve_problem()
// turns one into a Problem using forward-mode dual numbers (dual.hpp), so the
// Jacobian is exact. Ceres is used inside solve() only; no Ceres type appears here.
//
// What solve() does:
//  1. Levenberg–Marquardt (Ceres, DENSE_QR) with tolerances 1e-20 and up to 10000
//     iterations, from the start; then the same with an initial trust-region radius
//     of 1e-4 (this rescues starts that walk onto a plateau, e.g. NIST BoxBOD start
//     1). The result with the lower cost, re-evaluated at the returned parameters,
//     is kept (a run that ends in FAILURE is never trusted).
//  2. Without a robust loss: up to 20 Gauss–Newton steps (column-pivoted QR of the
//     column-scaled Jacobian), each kept only if it lowers the cost.
//  3. Covariance from the singular value decomposition of the Jacobian J of the
//     weighted residuals, after scaling each column to unit norm (parameter
//     scaling: this keeps badly scaled problems, cond(J) ~ 1e8, accurate):
//     C = D (Jₛᵀ Jₛ)⁺ D, Jₛ = J D. C is multiplied by σ̂² = χ²/(n − p) unless
//     absolute_sigma. A scaled singular value below 1e-12 of the largest makes the
//     covariance singular: no standard errors are reported then (NaN).
//  4. Standard errors √diag C; 95 % intervals value ± q·SE with q the Student t
//     quantile with n − p degrees of freedom (σ estimated) or the normal quantile
//     (absolute_sigma). Parameters fitted as a logarithm (Transform::kLog, e.g. the
//     erf width W > 0) report SE by the delta method (SE_W = W·SE_lnW) and the
//     interval exp(lnW ± q·SE_lnW).
//  5. Optional residual bootstrap (fixed seed, deterministic): resampled standardised
//     residuals (centred, inflated by √(n/(n−p))) added to the fitted curve; refits
//     from the estimate; percentile intervals.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "shearzone/fit/dual.hpp"

namespace shearzone::fit {

enum class Loss { kNone, kHuber, kCauchy };
/// How a parameter is represented inside the solver.
enum class Transform {
  kIdentity,
  kLog,  ///< solved as ln(p): keeps p > 0 (widths, amplitudes in log space)
};

/// "none", "huber", "cauchy"; parse_loss throws ConfigError on anything else.
const char* loss_name(Loss loss);
Loss parse_loss(const std::string& name);

struct FitOptions {
  bool absolute_sigma = false;  ///< σ are absolute standard deviations: no χ²_red scaling
  Loss loss = Loss::kNone;
  double loss_scale = 1.0;      ///< robust loss scale a, in units of the weighted residual
  int max_iterations = 10000;
  double tolerance = 1e-20;     ///< function, gradient and parameter tolerance
  int polish_steps = 20;        ///< Gauss–Newton polish (skipped with a robust loss)
  double confidence = 0.95;     ///< level of the intervals
  int bootstrap = 0;            ///< residual bootstrap resamples (0: none)
  std::uint64_t seed = 1;       ///< bootstrap seed

  /// ConfigError on a value out of range.
  void validate() const;
};

/// A least-squares problem: data y_i (σ_i) and a model f_i(p).
struct Problem {
  int num_params = 0;
  std::vector<std::string> names;       ///< one per parameter
  std::vector<Transform> transforms;    ///< empty: all identity
  std::vector<double> y;                ///< data, one per residual
  std::vector<double> sigma;            ///< empty: unity
  /// f_i(p) at the (reported) parameters p; with `grad` non-null also ∂f_i/∂p
  /// (num_params values). Returns false when the value is not finite.
  std::function<bool(int i, const double* p, double* f, double* grad)> model;

  int num_residuals() const { return static_cast<int>(y.size()); }
};

struct FitResult {
  std::vector<std::string> names;
  std::vector<double> start;            ///< starting values (reported parametrisation)
  std::vector<double> values;           ///< estimates
  std::vector<double> std_errors;       ///< NaN when the covariance is singular
  std::vector<double> ci_low, ci_high;  ///< confidence interval at options.confidence
  std::vector<double> boot_low, boot_high;  ///< bootstrap percentile interval (NaN: none)
  std::vector<double> covariance;       ///< p×p row-major, reported parametrisation
  std::vector<double> correlation;      ///< p×p row-major
  bool usable = false;                  ///< finite estimate from a solver run that did not fail
  bool converged = false;               ///< the kept run reported convergence
  bool covariance_ok = false;           ///< false: singular (rank-deficient) Jacobian
  std::string termination;              ///< CONVERGENCE, NO_CONVERGENCE, FAILURE, ...
  std::string message;                  ///< the solver's message
  std::string setting;                  ///< which solver setting was kept
  int iterations = 0;                   ///< solver iterations of the kept run (+ polish steps)
  int polish_steps = 0;                 ///< Gauss–Newton steps that lowered the cost
  int n = 0, p = 0, dof = 0;
  double initial_cost = 0.0, final_cost = 0.0;  ///< ½ Σ ρ(r²)
  double chi2 = 0.0;                    ///< Σ r² (weighted residual sum of squares)
  double reduced_chi2 = 0.0;            ///< χ² / max(1, dof)
  double aic = 0.0, aicc = 0.0, bic = 0.0;
  double cond = 0.0;                    ///< condition number of J (raw parameters)
  double cond_scaled = 0.0;             ///< condition number of J with unit-norm columns
  double quantile = 0.0;                ///< q used in the intervals
  double confidence = 0.95;             ///< level of the intervals
  bool absolute_sigma = false;
  Loss loss = Loss::kNone;
  double loss_scale = 1.0;
  int bootstrap_samples = 0, bootstrap_failures = 0;
  std::uint64_t seed = 0;
  std::vector<double> residuals;        ///< weighted residuals r_i at the estimate
  std::vector<double> fitted;           ///< f_i at the estimate
};

/// Solves `problem` from `start` (reported parametrisation). Never throws for a
/// failed fit: see FitResult::usable / converged / covariance_ok. Throws
/// ConfigError when the problem itself is malformed (sizes, σ ≤ 0).
FitResult solve(const Problem& problem, const std::vector<double>& start,
                const FitOptions& options = {});

/// A readable report in the style of lmfit's fit_report.
std::string fit_report(const FitResult& r, const std::string& title);

/// A Problem for y = Model(p, x) with the gradient from Dual<Model::kParams>.
/// Model: `static constexpr int kParams; template <class T> T operator()(const T* p,
/// double x) const`.
template <class Model>
Problem curve_problem(const Model& model, std::vector<double> x, std::vector<double> y,
                      std::vector<double> sigma, std::vector<std::string> names,
                      std::vector<Transform> transforms = {}) {
  constexpr int K = Model::kParams;
  Problem pr;
  pr.num_params = K;
  pr.names = std::move(names);
  pr.transforms = std::move(transforms);
  pr.y = std::move(y);
  pr.sigma = std::move(sigma);
  pr.model = [model, x = std::move(x)](int i, const double* p, double* f, double* grad) {
    const double xi = x[static_cast<std::size_t>(i)];
    if (grad == nullptr) {
      *f = model(p, xi);
      return std::isfinite(*f);
    }
    std::array<Dual<K>, K> pd;
    for (int k = 0; k < K; ++k) pd[static_cast<std::size_t>(k)] = Dual<K>::variable(p[k], k);
    const Dual<K> r = model(pd.data(), xi);
    *f = r.v;
    bool ok = std::isfinite(r.v);
    for (int k = 0; k < K; ++k) {
      grad[k] = r.d[static_cast<std::size_t>(k)];
      ok = ok && std::isfinite(grad[k]);
    }
    return ok;
  };
  return pr;
}

}  // namespace shearzone::fit
