#include "shearzone/fit/least_squares.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <mutex>
#include <random>

#include <Eigen/Dense>
#include <ceres/ceres.h>
#include <fmt/format.h>
#include <glog/logging.h>
#include <gsl/gsl_cdf.h>

#include "shearzone/core/error.hpp"
#include "shearzone/core/stats.hpp"
#include "shearzone/core/unset.hpp"

namespace shearzone::fit {

namespace {
/// Scaled singular values below this fraction of the largest make the covariance
/// singular. With unit-norm columns, cond(J D) above 1e12 means a parameter
/// combination is determined to fewer than ~4 of the ~16 digits of a double.
constexpr double kSingularRcond = 1e-12;

/// Relative cost increase tolerated by a polish step: ~100 ulp, the round-off of a
/// sum of squares of a few hundred terms.
constexpr double kPolishCostSlack = 1e-13;

using Matrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// The problem in the solver's (internal) parametrisation q: p_k = exp(q_k) for
/// log-transformed parameters.
class Internal {
 public:
  Internal(const Problem& pr, const std::vector<double>* y_override = nullptr)
      : pr_(pr), y_(y_override ? *y_override : pr.y) {
    p_ = pr.num_params;
    log_.assign(static_cast<std::size_t>(p_), false);
    for (std::size_t k = 0; k < pr.transforms.size(); ++k)
      log_[k] = pr.transforms[k] == Transform::kLog;
  }
  int p() const { return p_; }
  int n() const { return static_cast<int>(y_.size()); }
  bool is_log(int k) const { return log_[static_cast<std::size_t>(k)]; }
  const std::vector<double>& y() const { return y_; }
  double sigma(int i) const {
    return pr_.sigma.empty() ? 1.0 : pr_.sigma[static_cast<std::size_t>(i)];
  }

  std::vector<double> to_reported(const double* q) const {
    std::vector<double> out(q, q + p_);
    for (int k = 0; k < p_; ++k)
      if (is_log(k)) out[static_cast<std::size_t>(k)] = std::exp(q[k]);
    return out;
  }
  std::vector<double> to_internal(const std::vector<double>& p) const {
    std::vector<double> q = p;
    for (int k = 0; k < p_; ++k)
      if (is_log(k)) q[static_cast<std::size_t>(k)] = std::log(p[static_cast<std::size_t>(k)]);
    return q;
  }

  /// Weighted residual r_i and, optionally, ∂r_i/∂q (p values).
  bool residual(int i, const double* q, double* r, double* grad) const {
    const std::vector<double> pr = to_reported(q);
    double f = 0.0;
    if (!pr_.model(i, pr.data(), &f, grad)) return false;
    const double s = sigma(i);
    *r = (y_[static_cast<std::size_t>(i)] - f) / s;
    if (grad != nullptr)
      for (int k = 0; k < p_; ++k) {
        grad[k] *= -1.0 / s;
        if (is_log(k)) grad[k] *= pr[static_cast<std::size_t>(k)];
      }
    return std::isfinite(*r);
  }

  /// All residuals and (optionally) the Jacobian; false if anything is not finite.
  bool evaluate(const std::vector<double>& q, Eigen::VectorXd& r, Matrix* J) const {
    r.resize(n());
    if (J) J->resize(n(), p_);
    std::vector<double> g(static_cast<std::size_t>(p_));
    for (int i = 0; i < n(); ++i) {
      double ri = 0.0;
      if (!residual(i, q.data(), &ri, J ? g.data() : nullptr)) return false;
      r(i) = ri;
      if (J)
        for (int k = 0; k < p_; ++k) {
          if (!std::isfinite(g[static_cast<std::size_t>(k)])) return false;
          (*J)(i, k) = g[static_cast<std::size_t>(k)];
        }
    }
    return true;
  }

 private:
  const Problem& pr_;
  std::vector<double> y_;
  int p_ = 0;
  std::vector<bool> log_;
};

/// ρ(s) of the loss (Ceres conventions: ρ(s, a) = a² ρ(s / a²)) and ρ'(s).
double rho(Loss loss, double a, double s) {
  switch (loss) {
    case Loss::kHuber: return s <= a * a ? s : 2.0 * a * std::sqrt(s) - a * a;
    case Loss::kCauchy: return a * a * std::log1p(s / (a * a));
    case Loss::kNone: break;
  }
  return s;
}
double rho_prime(Loss loss, double a, double s) {
  switch (loss) {
    case Loss::kHuber: return s <= a * a ? 1.0 : a / std::sqrt(s);
    case Loss::kCauchy: return 1.0 / (1.0 + s / (a * a));
    case Loss::kNone: break;
  }
  return 1.0;
}

double cost_of(const Eigen::VectorXd& r, Loss loss, double a) {
  double c = 0.0;
  for (Eigen::Index i = 0; i < r.size(); ++i) c += rho(loss, a, r(i) * r(i));
  return 0.5 * c;
}

/// One residual of the problem as a Ceres cost function (1 residual, 1 block of p).
class ResidualCost final : public ceres::CostFunction {
 public:
  ResidualCost(const Internal& in, int i) : in_(in), i_(i) {
    set_num_residuals(1);
    mutable_parameter_block_sizes()->push_back(in.p());
  }
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    return in_.residual(i_, parameters[0], residuals,
                        jacobians != nullptr ? jacobians[0] : nullptr);
  }

 private:
  const Internal& in_;
  int i_;
};

struct RunResult {
  std::vector<double> q;
  double cost = std::numeric_limits<double>::infinity();
  bool usable = false;
  bool converged = false;
  std::string termination, message, setting;
  int iterations = 0;
};

RunResult run_ceres(const Internal& in, const std::vector<double>& q0, const FitOptions& o,
                    double initial_radius, const std::string& setting) {
  RunResult rr;
  rr.setting = setting;
  rr.q = q0;
  ceres::Problem::Options popt;
  popt.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  popt.loss_function_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem problem(popt);
  for (int i = 0; i < in.n(); ++i) {
    ceres::LossFunction* lf = nullptr;
    if (o.loss == Loss::kHuber) lf = new ceres::HuberLoss(o.loss_scale);
    if (o.loss == Loss::kCauchy) lf = new ceres::CauchyLoss(o.loss_scale);
    problem.AddResidualBlock(new ResidualCost(in, i), lf, rr.q.data());
  }
  ceres::Solver::Options so;
  so.minimizer_type = ceres::TRUST_REGION;
  so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  so.linear_solver_type = ceres::DENSE_QR;
  so.function_tolerance = o.tolerance;
  so.gradient_tolerance = o.tolerance;
  so.parameter_tolerance = o.tolerance;
  so.max_num_iterations = o.max_iterations;
  so.initial_trust_region_radius = initial_radius;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
  // Ceres reports through glog on stderr ("Logging before InitGoogleLogging()",
  // "Terminating: ..."): the outcome is in the summary, so its log stays silent.
  static std::once_flag quiet_glog;
  std::call_once(quiet_glog, [] {
    FLAGS_minloglevel = google::GLOG_FATAL;
    FLAGS_stderrthreshold = google::GLOG_FATAL;
    if (!google::IsGoogleLoggingInitialized()) google::InitGoogleLogging("shearzone");
  });
  ceres::Solver::Summary sum;
  ceres::Solve(so, &problem, &sum);
  rr.termination = ceres::TerminationTypeToString(sum.termination_type);
  rr.message = sum.message;
  rr.iterations = static_cast<int>(sum.iterations.size()) - 1;
  rr.converged = sum.termination_type == ceres::CONVERGENCE;
  // Judge by re-evaluating at the returned parameters, never by summary.final_cost.
  Eigen::VectorXd r;
  if (sum.IsSolutionUsable() && in.evaluate(rr.q, r, nullptr)) {
    rr.cost = cost_of(r, o.loss, o.loss_scale);
    rr.usable = std::isfinite(rr.cost);
  }
  return rr;
}

/// Gauss–Newton steps on the column-scaled Jacobian; a step is kept only if it
/// lowers the cost. Returns the number of steps kept.
int polish(const Internal& in, std::vector<double>& q, double& cost, int max_steps) {
  int kept = 0;
  for (int s = 0; s < max_steps; ++s) {
    Eigen::VectorXd r;
    Matrix J;
    if (!in.evaluate(q, r, &J)) break;
    Eigen::VectorXd scale(in.p());
    for (int k = 0; k < in.p(); ++k) {
      const double nrm = J.col(k).norm();
      scale(k) = nrm > 0 ? 1.0 / nrm : 1.0;
    }
    const Matrix Js = J * scale.asDiagonal();
    const Eigen::VectorXd step = scale.asDiagonal() * Js.colPivHouseholderQr().solve(-r);
    if (!step.allFinite()) break;
    std::vector<double> qn = q;
    for (int k = 0; k < in.p(); ++k) qn[static_cast<std::size_t>(k)] += step(k);
    Eigen::VectorXd rn;
    if (!in.evaluate(qn, rn, nullptr)) break;
    const double cn = 0.5 * rn.squaredNorm();
    // Near the minimum the cost change is at the round-off level of the cost while
    // the parameters still move along flat directions: a step is kept unless it
    // raises the cost by more than that round-off level.
    if (!(cn <= cost * (1.0 + kPolishCostSlack) + std::numeric_limits<double>::min())) break;
    bool moved = false;
    for (int k = 0; k < in.p(); ++k)
      moved = moved || qn[static_cast<std::size_t>(k)] != q[static_cast<std::size_t>(k)];
    q = qn;
    cost = cn;
    ++kept;
    if (!moved) break;
  }
  return kept;
}

/// The best of the two LM settings, then the polish.
RunResult minimise(const Internal& in, const std::vector<double>& q0, const FitOptions& o,
                   bool both_settings) {
  RunResult best = run_ceres(in, q0, o, 1e4, "LM, initial trust region 1e4");
  if (both_settings || !best.usable || !best.converged) {
    RunResult second = run_ceres(in, q0, o, 1e-4, "LM, initial trust region 1e-4");
    if (second.usable && (!best.usable || second.cost < best.cost ||
                          (!best.converged && second.converged && second.cost <= best.cost)))
      best = std::move(second);
  }
  return best;
}

double quantile_for(const FitOptions& o, int dof) {
  const double pr = 0.5 + 0.5 * o.confidence;
  if (o.absolute_sigma) return gsl_cdf_ugaussian_Pinv(pr);
  return dof > 0 ? gsl_cdf_tdist_Pinv(pr, dof) : core::kUnset;
}

}  // namespace

const char* loss_name(Loss loss) {
  switch (loss) {
    case Loss::kHuber: return "huber";
    case Loss::kCauchy: return "cauchy";
    case Loss::kNone: break;
  }
  return "none";
}

Loss parse_loss(const std::string& name) {
  if (name == "none") return Loss::kNone;
  if (name == "huber") return Loss::kHuber;
  if (name == "cauchy") return Loss::kCauchy;
  throw ConfigError(fmt::format("--loss \"{}\": expected none, huber or cauchy", name));
}

void FitOptions::validate() const {
  if (!(loss_scale > 0) || !std::isfinite(loss_scale))
    throw ConfigError(fmt::format("loss scale {}: must be a positive number", loss_scale));
  if (!(confidence > 0 && confidence < 1))
    throw ConfigError(fmt::format("confidence {}: must be in (0, 1)", confidence));
  if (bootstrap < 0 || bootstrap > 100000)
    throw ConfigError(fmt::format("bootstrap {}: expected 0..100000 resamples", bootstrap));
  if (max_iterations < 1) throw ConfigError("max iterations: must be >= 1");
}

FitResult solve(const Problem& pr, const std::vector<double>& start, const FitOptions& o) {
  o.validate();
  const int p = pr.num_params;
  if (p < 1 || static_cast<int>(start.size()) != p ||
      (!pr.names.empty() && static_cast<int>(pr.names.size()) != p) ||
      (!pr.transforms.empty() && static_cast<int>(pr.transforms.size()) != p) || !pr.model)
    throw ConfigError("fit: malformed problem (parameter counts disagree)");
  if (!pr.sigma.empty() && pr.sigma.size() != pr.y.size())
    throw ConfigError("fit: sigma and y have different lengths");
  for (double s : pr.sigma)
    if (!(s > 0) || !std::isfinite(s))
      throw ConfigError(fmt::format("fit: sigma {} is not a positive number", s));

  const Internal in(pr);
  FitResult res;
  res.names = pr.names;
  if (res.names.empty())
    for (int k = 0; k < p; ++k) res.names.push_back(fmt::format("b{}", k + 1));
  res.start = start;
  res.n = in.n();
  res.p = p;
  res.dof = res.n - p;
  res.absolute_sigma = o.absolute_sigma;
  res.loss = o.loss;
  res.loss_scale = o.loss_scale;
  res.seed = o.seed;
  res.confidence = o.confidence;
  const auto nan_vec = [p] { return std::vector<double>(static_cast<std::size_t>(p), core::kUnset); };
  res.values = res.std_errors = res.ci_low = res.ci_high = res.boot_low = res.boot_high = nan_vec();
  res.quantile = quantile_for(o, res.dof);

  for (int k = 0; k < p; ++k)
    if (in.is_log(k) && !(start[static_cast<std::size_t>(k)] > 0)) {
      res.termination = "FAILURE";
      res.message = fmt::format("start value of {} must be > 0 (fitted as a logarithm)",
                                res.names[static_cast<std::size_t>(k)]);
      return res;
    }
  const std::vector<double> q0 = in.to_internal(start);
  {
    Eigen::VectorXd r0;
    if (in.evaluate(q0, r0, nullptr)) res.initial_cost = cost_of(r0, o.loss, o.loss_scale);
    else res.initial_cost = core::kUnset;
  }
  if (res.n < 1) {
    res.termination = "FAILURE";
    res.message = "no data";
    return res;
  }

  RunResult run = minimise(in, q0, o, true);
  res.termination = run.termination;
  res.message = run.message;
  res.setting = run.setting;
  res.iterations = run.iterations;
  res.converged = run.converged;
  res.usable = run.usable;
  if (!run.usable) return res;
  if (o.loss == Loss::kNone && o.polish_steps > 0) {
    res.polish_steps = polish(in, run.q, run.cost, o.polish_steps);
    res.iterations += res.polish_steps;
  }
  res.final_cost = run.cost;
  res.values = in.to_reported(run.q.data());

  Eigen::VectorXd r;
  Matrix J;
  if (!in.evaluate(run.q, r, &J)) {
    res.usable = false;
    res.message += "; residuals not finite at the estimate";
    return res;
  }
  res.residuals.assign(r.data(), r.data() + r.size());
  res.fitted.resize(static_cast<std::size_t>(res.n));
  for (int i = 0; i < res.n; ++i)
    res.fitted[static_cast<std::size_t>(i)] =
        pr.y[static_cast<std::size_t>(i)] - r(i) * in.sigma(i);
  res.chi2 = r.squaredNorm();
  res.reduced_chi2 = res.chi2 / std::max(1, res.dof);
  const double n = res.n;
  const double lnc = std::log(std::max(res.chi2, std::numeric_limits<double>::min()) / n);
  res.aic = n * lnc + 2.0 * p;
  res.bic = n * lnc + p * std::log(n);
  res.aicc = res.n - p - 1 > 0 ? res.aic + 2.0 * p * (p + 1) / (n - p - 1) : core::kUnset;

  // Robust loss: covariance from the reweighted Jacobian (Gauss–Newton
  // approximation at the robust weights ρ'(r²)).
  if (o.loss != Loss::kNone)
    for (int i = 0; i < res.n; ++i) J.row(i) *= std::sqrt(rho_prime(o.loss, o.loss_scale, r(i) * r(i)));

  {
    const Eigen::JacobiSVD<Matrix> raw(J);
    const auto& s = raw.singularValues();
    res.cond = s(s.size() - 1) > 0 ? s(0) / s(s.size() - 1) : std::numeric_limits<double>::infinity();
  }
  Eigen::VectorXd scale(p);
  bool zero_column = false;
  for (int k = 0; k < p; ++k) {
    const double nrm = J.col(k).norm();
    zero_column = zero_column || !(nrm > 0);
    scale(k) = nrm > 0 ? 1.0 / nrm : 1.0;
  }
  const Matrix Js = J * scale.asDiagonal();
  const Eigen::JacobiSVD<Matrix> svd(Js, Eigen::ComputeThinV);
  const auto& s = svd.singularValues();
  res.cond_scaled = s(s.size() - 1) > 0 ? s(0) / s(s.size() - 1) : std::numeric_limits<double>::infinity();
  const bool enough = o.absolute_sigma ? res.dof >= 0 : res.dof > 0;
  res.covariance_ok = !zero_column && res.n >= p && s(s.size() - 1) > kSingularRcond * s(0) && enough;
  res.covariance.assign(static_cast<std::size_t>(p * p), core::kUnset);
  res.correlation.assign(static_cast<std::size_t>(p * p), core::kUnset);
  if (res.covariance_ok) {
    const Eigen::VectorXd inv2 = s.array().inverse().square();
    const Matrix V = svd.matrixV();
    Matrix Cq = scale.asDiagonal() * (V * inv2.asDiagonal() * V.transpose()) * scale.asDiagonal();
    if (!o.absolute_sigma) Cq *= 2.0 * res.final_cost / res.dof;
    // Reported parametrisation: dp/dq = p for log parameters (delta method).
    Eigen::VectorXd d(p);
    for (int k = 0; k < p; ++k) d(k) = in.is_log(k) ? res.values[static_cast<std::size_t>(k)] : 1.0;
    const Matrix C = d.asDiagonal() * Cq * d.asDiagonal();
    for (int a = 0; a < p; ++a)
      for (int b = 0; b < p; ++b) {
        res.covariance[static_cast<std::size_t>(a * p + b)] = C(a, b);
        res.correlation[static_cast<std::size_t>(a * p + b)] =
            Cq(a, b) / std::sqrt(Cq(a, a) * Cq(b, b));
      }
    for (int k = 0; k < p; ++k) {
      const auto kk = static_cast<std::size_t>(k);
      const double seq = std::sqrt(Cq(k, k));
      res.std_errors[kk] = std::sqrt(C(k, k));
      const double q = run.q[kk];
      if (in.is_log(k)) {
        res.ci_low[kk] = std::exp(q - res.quantile * seq);
        res.ci_high[kk] = std::exp(q + res.quantile * seq);
      } else {
        res.ci_low[kk] = q - res.quantile * seq;
        res.ci_high[kk] = q + res.quantile * seq;
      }
    }
  }

  if (o.bootstrap > 0 && res.n > p) {
    // Residual bootstrap on the standardised residuals (centred, leverage-inflated).
    std::vector<double> e(res.residuals);
    double mean = 0.0;
    for (double v : e) mean += v;
    mean /= static_cast<double>(e.size());
    const double infl = std::sqrt(n / (n - p));
    for (double& v : e) v = (v - mean) * infl;
    std::mt19937_64 rng(o.seed);
    FitOptions bo = o;
    bo.bootstrap = 0;
    bo.tolerance = 1e-14;
    bo.max_iterations = 500;
    std::vector<std::vector<double>> samples(static_cast<std::size_t>(p));
    std::vector<double> ystar(static_cast<std::size_t>(res.n));
    for (int b = 0; b < o.bootstrap; ++b) {
      for (int i = 0; i < res.n; ++i) {
        const std::size_t j = static_cast<std::size_t>(rng() % e.size());
        ystar[static_cast<std::size_t>(i)] =
            res.fitted[static_cast<std::size_t>(i)] + in.sigma(i) * e[j];
      }
      const Internal bin(pr, &ystar);
      RunResult br = minimise(bin, run.q, bo, false);
      if (!br.usable) {
        ++res.bootstrap_failures;
        continue;
      }
      const std::vector<double> v = bin.to_reported(br.q.data());
      for (int k = 0; k < p; ++k) samples[static_cast<std::size_t>(k)].push_back(v[static_cast<std::size_t>(k)]);
      ++res.bootstrap_samples;
    }
    const double alpha = 1.0 - o.confidence;
    for (int k = 0; k < p; ++k) {
      const auto kk = static_cast<std::size_t>(k);
      res.boot_low[kk] = core::percentile(samples[kk], 0.5 * alpha);
      res.boot_high[kk] = core::percentile(samples[kk], 1.0 - 0.5 * alpha);
    }
  }
  return res;
}

std::string fit_report(const FitResult& r, const std::string& title) {
  std::string s = fmt::format("[[Fit: {}]]\n", title);
  s += fmt::format("    termination        = {} ({}), {} iterations, setting: {}\n", r.termination,
                   r.message, r.iterations, r.setting.empty() ? "-" : r.setting);
  s += fmt::format("    data points        = {}\n    variables          = {}\n    dof                = {}\n",
                   r.n, r.p, r.dof);
  s += fmt::format("    chi-square         = {:.6g}\n    reduced chi-square = {:.6g}\n", r.chi2,
                   r.reduced_chi2);
  s += fmt::format("    AIC = {:.4f}   AICc = {:.4f}   BIC = {:.4f}\n", r.aic, r.aicc, r.bic);
  s += fmt::format("    cond(J) = {:.3g} (columns scaled: {:.3g})\n", r.cond, r.cond_scaled);
  s += fmt::format("    sigma: {}; loss: {}", r.absolute_sigma ? "absolute" : "scaled by reduced chi-square",
                   loss_name(r.loss));
  if (r.loss != Loss::kNone) s += fmt::format(" (scale {})", r.loss_scale);
  s += "\n[[Variables]]\n";
  for (std::size_t k = 0; k < r.values.size(); ++k) {
    const double rel = 100.0 * r.std_errors[k] / std::fabs(r.values[k]);
    s += fmt::format("    {:<8} = {:<14.8g} +/- {:<11.4g} ({:.2f}%)  {:.0f}% CI [{:.6g}, {:.6g}]  (init = {:.6g})\n",
                     r.names[k], r.values[k], r.std_errors[k], rel, 100.0 * r.confidence,
                     r.ci_low[k], r.ci_high[k], r.start[k]);
    if (r.bootstrap_samples > 0)
      s += fmt::format("    {:<8}   bootstrap interval [{:.6g}, {:.6g}] ({} resamples, {} failed)\n", "",
                       r.boot_low[k], r.boot_high[k], r.bootstrap_samples, r.bootstrap_failures);
  }
  if (!r.covariance_ok) s += "    (covariance singular: no standard errors)\n";
  s += "[[Correlations]] (|C| > 0.1)\n";
  const std::size_t p = r.values.size();
  for (std::size_t a = 0; a < p; ++a)
    for (std::size_t b = a + 1; b < p; ++b) {
      const double c = r.correlation[a * p + b];
      if (std::fabs(c) > 0.1)
        s += fmt::format("    C({}, {}) = {:+.4f}{}\n", r.names[a], r.names[b], c,
                         std::fabs(c) > 0.95 ? "  (strong)" : "");
    }
  if (r.cond > 1e7) s += "    warning: cond(J) > 1e7 (raw parameters)\n";
  return s;
}

}  // namespace shearzone::fit
