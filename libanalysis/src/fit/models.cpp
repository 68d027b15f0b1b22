#include "shearzone/fit/models.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <utility>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"

namespace shearzone::fit {
namespace {

/// y varies by less than this fraction of its magnitude: flat (a step of 1e-12 is
/// round-off of values written with 12–17 digits, not a transition).
constexpr double kFlatRelative = 1e-12;

bool is_flat(const std::vector<double>& y) {
  const auto [lo, hi] = std::minmax_element(y.begin(), y.end());
  const double mag = std::max(std::fabs(*lo), std::fabs(*hi));
  return !(*hi - *lo > kFlatRelative * mag) ;
}

/// First x where the sorted, normalised data cross `level` (upwards), by linear
/// interpolation; NaN if they never do.
double crossing(const std::vector<double>& xs, const std::vector<double>& ys, double level) {
  if (!ys.empty() && ys.front() >= level) return xs.front();
  for (std::size_t i = 1; i < xs.size(); ++i)
    if (ys[i - 1] < level && ys[i] >= level) {
      const double t = (level - ys[i - 1]) / (ys[i] - ys[i - 1]);
      return xs[i - 1] + t * (xs[i] - xs[i - 1]);
    }
  return std::nan("");
}

/// ln y = ln A + k·ln x as a function of u = ln x (A is solved as ln A).
struct LogPower {
  static constexpr int kParams = 2;
  template <class T>
  T operator()(const T* q, double u) const {
    using std::log;
    return log(q[0]) + q[1] * u;
  }
};

CurveFit status_only(FitStatus s, std::string msg) {
  CurveFit c;
  c.status = s;
  c.message = std::move(msg);
  return c;
}

/// Sets the status of a finished solver run (no convergence, singular covariance).
void classify(CurveFit& c) {
  const FitResult& r = c.result;
  c.has_result = r.usable;
  if (!r.usable || !r.converged) {
    c.status = FitStatus::kNoConvergence;
    c.message = fmt::format("solver: {}: {}", r.termination, r.message);
    return;
  }
  if (!r.covariance_ok) {
    c.status = FitStatus::kSingularCovariance;
    c.message = fmt::format("rank-deficient Jacobian (cond = {:.3g} with scaled columns)", r.cond_scaled);
    return;
  }
  c.status = FitStatus::kOk;
  c.message.clear();
}

std::size_t min_points(int p, const FitOptions& o) {
  return static_cast<std::size_t>(o.absolute_sigma ? p : p + 1);
}

}  // namespace

const char* status_name(FitStatus s) {
  switch (s) {
    case FitStatus::kOk: return "ok";
    case FitStatus::kTooFewPoints: return "too_few_points";
    case FitStatus::kFlatData: return "flat_data";
    case FitStatus::kTransitionOutsideRange: return "transition_outside_range";
    case FitStatus::kTransitionUnresolved: return "transition_unresolved";
    case FitStatus::kNonPositiveValues: return "nonpositive_values";
    case FitStatus::kNoConvergence: return "no_convergence";
    case FitStatus::kSingularCovariance: return "singular_covariance";
  }
  return "?";
}

std::array<double, 4> erf_start(const std::vector<double>& x, const std::vector<double>& y) {
  std::vector<std::size_t> idx(x.size());
  std::iota(idx.begin(), idx.end(), 0);
  std::stable_sort(idx.begin(), idx.end(), [&](std::size_t a, std::size_t b) { return x[a] < x[b]; });
  std::vector<double> xs, ys;
  for (std::size_t i : idx) {
    xs.push_back(x[i]);
    ys.push_back(y[i]);
  }
  const std::size_t n = xs.size();
  const std::size_t k = std::clamp<std::size_t>(n / 4, 1, 3);
  double lo = 0.0, hi = 0.0;
  for (std::size_t i = 0; i < k; ++i) {
    lo += ys[i];
    hi += ys[n - 1 - i];
  }
  lo /= static_cast<double>(k);
  hi /= static_cast<double>(k);
  const double range = xs.back() - xs.front();
  std::vector<double> yn(n);
  for (std::size_t i = 0; i < n; ++i) yn[i] = hi != lo ? (ys[i] - lo) / (hi - lo) : 0.5;
  double phic = crossing(xs, yn, 0.5);
  if (!std::isfinite(phic)) phic = 0.5 * (xs.front() + xs.back());
  const double x16 = crossing(xs, yn, 0.1587);
  const double x84 = crossing(xs, yn, 0.8413);
  double w = std::sqrt(2.0) * 0.5 * (x84 - x16);  // W = √2 × Gaussian σ
  if (!(w > 0) || !std::isfinite(w)) w = range > 0 ? range / 10.0 : 1.0;
  // A step sharper than the sampling cannot be resolved; start at a width the data see.
  if (n > 1 && range > 0) w = std::max(w, 0.25 * range / static_cast<double>(n - 1));
  return {lo, hi, phic, w};
}

CurveFit fit_erf(const std::vector<double>& x, const std::vector<double>& y,
                 const std::vector<double>& sigma, const FitOptions& o) {
  constexpr int p = ErfTransition::kParams;
  if (x.size() < min_points(p, o))
    return status_only(FitStatus::kTooFewPoints,
                       fmt::format("{} points for {} parameters{}", x.size(), p,
                                   o.absolute_sigma ? "" : " (+1 to estimate sigma)"));
  if (is_flat(y)) return status_only(FitStatus::kFlatData, "y does not vary: no transition");
  const auto s = erf_start(x, y);
  CurveFit c;
  c.result = solve(curve_problem(ErfTransition{}, x, y, sigma, {"rc0", "rcinf", "phi_c", "W"},
                                 {Transform::kIdentity, Transform::kIdentity, Transform::kIdentity,
                                  Transform::kLog}),
                   {s[0], s[1], s[2], s[3]}, o);
  classify(c);
  if (c.status == FitStatus::kOk || c.status == FitStatus::kSingularCovariance) {
    const auto [lo, hi] = std::minmax_element(x.begin(), x.end());
    const double phic = c.result.values[2];
    if (phic < *lo || phic > *hi) {
      c.status = FitStatus::kTransitionOutsideRange;
      c.message = fmt::format("phi_c = {:.6g} lies outside the sampled x range [{:.6g}, {:.6g}]",
                              phic, *lo, *hi);
    } else {
      // A transition sharper than the sampling: with fewer than two points inside
      // phi_c +- W, the data fix neither W nor phi_c (their errors blow up), only
      // that W is below the local spacing of x.
      const double W = c.result.values[3];
      const auto inside = std::count_if(x.begin(), x.end(), [&](double v) { return std::abs(v - phic) < W; });
      if (inside < 2) {
        c.status = FitStatus::kTransitionUnresolved;
        c.message = fmt::format("only {} point(s) within phi_c +- W = {:.6g} +- {:.6g}: the transition "
                                "is sharper than the sampling of x; sample phi0 more finely there",
                                inside, phic, W);
      }
    }
  }
  return c;
}

PowerSpace parse_power_space(const std::string& name) {
  if (name == "linear") return PowerSpace::kLinear;
  if (name == "log") return PowerSpace::kLog;
  throw ConfigError(fmt::format("--space \"{}\": expected linear or log", name));
}

namespace {

/// Unweighted least-squares line y = b + k x: returns (b, k). x must vary.
std::pair<double, double> line_through(const std::vector<double>& x, const std::vector<double>& y) {
  const double mx = std::accumulate(x.begin(), x.end(), 0.0) / static_cast<double>(x.size());
  const double my = std::accumulate(y.begin(), y.end(), 0.0) / static_cast<double>(y.size());
  double sxy = 0, sxx = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    sxy += (x[i] - mx) * (y[i] - my);
    sxx += (x[i] - mx) * (x[i] - mx);
  }
  const double k = sxy / sxx;
  return {my - k * mx, k};
}

}  // namespace

CurveFit fit_power(const std::vector<double>& x, const std::vector<double>& y,
                   const std::vector<double>& sigma, PowerSpace space, const FitOptions& o) {
  constexpr int p = PowerLaw::kParams;
  if (x.size() < min_points(p, o))
    return status_only(FitStatus::kTooFewPoints,
                       fmt::format("{} points for {} parameters{}", x.size(), p,
                                   o.absolute_sigma ? "" : " (+1 to estimate sigma)"));
  for (double v : x)
    if (!(v > 0))
      return status_only(FitStatus::kNonPositiveValues,
                         fmt::format("x = {:.6g} <= 0: a power law needs x > 0", v));
  if (is_flat(y) && space == PowerSpace::kLinear && std::all_of(y.begin(), y.end(), [](double v) { return v == 0; }))
    return status_only(FitStatus::kFlatData, "y is zero everywhere");
  const bool all_positive = std::all_of(y.begin(), y.end(), [](double v) { return v > 0; });
  if (space == PowerSpace::kLog && !all_positive)
    return status_only(FitStatus::kNonPositiveValues, "y <= 0: no logarithm (use --space linear)");

  // The log–log line: the start in linear space, the fit itself in log space.
  std::vector<double> lx(x.size()), ly(y.size()), ls;
  for (std::size_t i = 0; i < x.size(); ++i) lx[i] = std::log(x[i]);
  const auto [xlo, xhi] = std::minmax_element(lx.begin(), lx.end());
  if (!(*xhi > *xlo))
    return status_only(FitStatus::kTooFewPoints, "all x are equal: the exponent is undetermined");
  CurveFit c;
  if (space == PowerSpace::kLog) {
    for (std::size_t i = 0; i < y.size(); ++i) ly[i] = std::log(y[i]);
    if (!sigma.empty())
      for (std::size_t i = 0; i < y.size(); ++i) ls.push_back(sigma[i] / y[i]);
    // Start: unweighted line through the logs.
    const auto [b, k] = line_through(lx, ly);
    c.result = solve(curve_problem(LogPower{}, lx, ly, ls, {"A", "k"},
                                   {Transform::kLog, Transform::kIdentity}),
                     {std::exp(b), k}, o);
  } else {
    double k = 1.0, a = 1.0;
    if (all_positive) {
      for (std::size_t i = 0; i < y.size(); ++i) ly[i] = std::log(y[i]);
      const auto [b, slope] = line_through(lx, ly);
      k = slope;
      a = std::exp(b);
    } else {
      // Mixed signs: the line through log|y| of the points with y != 0, sign of the mean.
      double mean = 0;
      for (double v : y) mean += v;
      std::vector<double> px, py;
      for (std::size_t i = 0; i < y.size(); ++i)
        if (y[i] != 0) {
          px.push_back(lx[i]);
          py.push_back(std::log(std::fabs(y[i])));
        }
      if (px.size() >= 2) {
        const double mx = std::accumulate(px.begin(), px.end(), 0.0) / static_cast<double>(px.size());
        const double my = std::accumulate(py.begin(), py.end(), 0.0) / static_cast<double>(py.size());
        double sxy = 0, sxx = 0;
        for (std::size_t i = 0; i < px.size(); ++i) {
          sxy += (px[i] - mx) * (py[i] - my);
          sxx += (px[i] - mx) * (px[i] - mx);
        }
        if (sxx > 0) k = sxy / sxx;
        a = std::copysign(std::exp(my - k * mx), mean);
      }
    }
    c.result = solve(curve_problem(PowerLaw{}, x, y, sigma, {"A", "k"}), {a, k}, o);
  }
  classify(c);
  return c;
}

bool subtract_at(std::vector<double>& x, std::vector<double>& y, std::vector<double>& sigma,
                 double x0, double rtol, double* y0_out, double* sigma0_out) {
  const double tol = rtol * std::max(std::fabs(x0), 1e-300);
  double sw = 0, swy = 0;
  std::size_t found = 0;
  for (std::size_t i = 0; i < x.size(); ++i)
    if (std::fabs(x[i] - x0) <= tol) {
      const double w = sigma.empty() ? 1.0 : 1.0 / (sigma[i] * sigma[i]);
      sw += w;
      swy += w * y[i];
      ++found;
    }
  if (found == 0) return false;
  const double y0 = swy / sw;
  const double s0 = sigma.empty() ? 0.0 : std::sqrt(1.0 / sw);
  std::vector<double> nx, ny, ns;
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (std::fabs(x[i] - x0) <= tol) continue;
    nx.push_back(x[i]);
    ny.push_back(y[i] - y0);
    if (!sigma.empty()) ns.push_back(std::sqrt(sigma[i] * sigma[i] + s0 * s0));
  }
  x = std::move(nx);
  y = std::move(ny);
  sigma = std::move(ns);
  if (y0_out) *y0_out = y0;
  if (sigma0_out) *sigma0_out = s0;
  return true;
}

}  // namespace shearzone::fit
