// Houdayer-Hartmann collapse quality, its Nelder-Mead minimisation (GSL nmsimplex2)
// and the S+1 / bootstrap errors. See shearzone/fit/collapse_fss.hpp.
#include "shearzone/fit/collapse_fss.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <random>

#include <fmt/format.h>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_multimin.h>
#include <gsl/gsl_vector.h>

#include "shearzone/core/enum_names.hpp"
#include "shearzone/core/error.hpp"
#include "shearzone/core/unset.hpp"

namespace shearzone::fit {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
/// Value the simplex sees where S is undefined (no term) or not finite: far above any
/// real S, finite because nmsimplex2 rejects non-finite values.
constexpr double kPenalty = 1e100;

/// Scaled coordinates of every curve at one parameter set.
struct Scaled {
  std::vector<std::vector<double>> xs, ys, dys;
};

void scale(const FssDataSet& d, const FssParams& p, Scaled& s) {
  const std::size_t k = d.curves.size();
  s.xs.resize(k);
  s.ys.resize(k);
  s.dys.resize(k);
  for (std::size_t c = 0; c < k; ++c) {
    const auto& cv = d.curves[c];
    const double fa = std::pow(cv.L, p[1]), fb = std::pow(cv.L, p[2]);
    const std::size_t n = cv.x.size();
    s.xs[c].resize(n);
    s.ys[c].resize(n);
    s.dys[c].resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      s.xs[c][i] = (cv.x[i] - p[0]) * fa;
      s.ys[c][i] = cv.y[i] * fb;
      s.dys[c][i] = cv.dy[i] * fb;
    }
  }
}

bool present(const FssWeights& w, std::size_t c, std::size_t i) {
  return w.empty() || w[c][i] > 0.0;
}

/// Master-curve value Y and variance dY^2 at scaled x `xi`, from the bracketing pairs
/// of every curve except `self`. The line is fitted in u = x - xi, so Y is its
/// intercept and dY^2 = S_uu / (S S_uu - S_u^2) (weights 1/dy^2). False if no other
/// curve brackets xi.
bool master_at(const Scaled& s, const FssWeights& w, std::size_t self, double xi, double& Y,
               double& dY2) {
  double K = 0, Ku = 0, Ky = 0, Kuu = 0, Kuy = 0;
  bool any = false;
  for (std::size_t c = 0; c < s.xs.size(); ++c) {
    if (c == self) continue;
    const auto& x = s.xs[c];
    // ih: first present point with x > xi; il: last present point with x <= xi.
    std::size_t ih = static_cast<std::size_t>(std::upper_bound(x.begin(), x.end(), xi) - x.begin());
    while (ih < x.size() && !present(w, c, ih)) ++ih;
    if (ih == x.size()) continue;
    std::size_t il = static_cast<std::size_t>(std::upper_bound(x.begin(), x.end(), xi) - x.begin());
    bool found = false;
    while (il > 0) {
      --il;
      if (present(w, c, il)) {
        found = true;
        break;
      }
    }
    if (!found) continue;
    for (const std::size_t j : {il, ih}) {
      const double wt = 1.0 / (s.dys[c][j] * s.dys[c][j]);
      const double u = x[j] - xi, y = s.ys[c][j];
      K += wt;
      Ku += wt * u;
      Ky += wt * y;
      Kuu += wt * u * u;
      Kuy += wt * u * y;
    }
    any = true;
  }
  if (!any) return false;
  const double fac = K * Kuu - Ku * Ku;
  if (!(fac > 0.0)) return false;
  Y = (Ky * Kuu - Ku * Kuy) / fac;
  dY2 = Kuu / fac;
  return true;
}

bool in_window(const FssWindow& win, double x) { return x >= win.lo && x <= win.hi; }

FssQuality quality_scaled(const Scaled& s, const FssWindow& win, const FssWeights& w) {
  double sum = 0.0, count = 0.0;
  std::size_t n = 0;
  for (std::size_t c = 0; c < s.xs.size(); ++c)
    for (std::size_t i = 0; i < s.xs[c].size(); ++i) {
      if (!present(w, c, i)) continue;
      const double xi = s.xs[c][i];
      if (!in_window(win, xi)) continue;
      double Y, dY2;
      if (!master_at(s, w, c, xi, Y, dY2)) continue;
      const double r = s.ys[c][i] - Y;
      const double m = w.empty() ? 1.0 : w[c][i];
      sum += m * r * r / (s.dys[c][i] * s.dys[c][i] + dY2);
      count += m;
      ++n;
    }
  FssQuality q;
  q.n_terms = n;
  if (n > 0) q.S = sum / count;
  return q;
}

/// The objective of the simplex: free parameters in units of their steps, relative
/// to `origin`.
struct Objective {
  const FssDataSet* data;
  const FssWeights* weights;
  const FssWindow* window;
  FssParams origin, step;
  std::vector<std::size_t> free;
  Scaled scratch;
  int evaluations = 0;

  FssParams params(const gsl_vector* u) const {
    FssParams p = origin;
    for (std::size_t k = 0; k < free.size(); ++k)
      p[free[k]] = origin[free[k]] + gsl_vector_get(u, k) * step[free[k]];
    return p;
  }
  double value(const FssParams& p) {
    ++evaluations;
    scale(*data, p, scratch);
    const FssQuality q = quality_scaled(scratch, *window, *weights);
    return (q.n_terms == 0 || !std::isfinite(q.S)) ? kPenalty : q.S;
  }
};

double gsl_objective(const gsl_vector* u, void* ctx) {
  auto* o = static_cast<Objective*>(ctx);
  return o->value(o->params(u));
}

struct MinResult {
  FssParams p{};
  double S = kPenalty;
  int evaluations = 0;
  int restarts = 0;
  bool converged = false;
};

/// Nelder-Mead from `start`, restarted from its optimum (fresh simplex of one step
/// per parameter) while S still decreases: the usual remedy for a simplex that
/// collapsed early, which a discontinuous S makes likely.
MinResult minimise(const FssDataSet& data, const FssWeights& weights, const FssFitOptions& o,
                   const FssParams& start, const FssParams& step) {
  Objective obj{&data, &weights, &o.window, start, step, {}, {}, 0};
  for (std::size_t k = 0; k < 3; ++k)
    if (!o.fixed[k]) obj.free.push_back(k);
  MinResult r;
  r.p = start;
  r.S = obj.value(start);
  if (obj.free.empty()) {
    r.evaluations = obj.evaluations;
    r.converged = true;
    return r;
  }
  const std::size_t n = obj.free.size();
  gsl_multimin_fminimizer* m = gsl_multimin_fminimizer_alloc(gsl_multimin_fminimizer_nmsimplex2, n);
  gsl_vector* x0 = gsl_vector_alloc(n);
  gsl_vector* ss = gsl_vector_alloc(n);
  if (m == nullptr || x0 == nullptr || ss == nullptr) throw std::bad_alloc();
  gsl_multimin_function f{&gsl_objective, n, &obj};
  for (int run = 0; run <= o.max_restarts; ++run) {
    obj.origin = r.p;
    gsl_vector_set_zero(x0);
    gsl_vector_set_all(ss, 1.0);
    if (gsl_multimin_fminimizer_set(m, &f, x0, ss) != GSL_SUCCESS) break;
    bool conv = false;
    for (int it = 0; it < o.max_iterations; ++it) {
      if (gsl_multimin_fminimizer_iterate(m) != GSL_SUCCESS) break;
      if (gsl_multimin_test_size(gsl_multimin_fminimizer_size(m), o.tolerance) == GSL_SUCCESS) {
        conv = true;
        break;
      }
    }
    const double fmin = gsl_multimin_fminimizer_minimum(m);
    r.converged = conv;
    if (run > 0) ++r.restarts;
    if (!(fmin < r.S)) break;  // no improvement: done
    r.S = fmin;
    r.p = obj.params(gsl_multimin_fminimizer_x(m));
  }
  gsl_vector_free(ss);
  gsl_vector_free(x0);
  gsl_multimin_fminimizer_free(m);
  r.evaluations = obj.evaluations;
  return r;
}

/// One side of the S+1 error of parameter k: the distance from `best` at which S first
/// reaches `target` (expanding scan from 1e-3 step, doubling, then bisection).
double splus1_side(const FssDataSet& data, const FssWindow& win, const FssParams& best,
                   std::size_t k, double sign, double step, double target) {
  Scaled s;
  auto S_at = [&](double d) {
    FssParams p = best;
    p[k] += sign * d;
    scale(data, p, s);
    const FssQuality q = quality_scaled(s, win, {});
    return (q.n_terms == 0 || !std::isfinite(q.S)) ? kInf : q.S;
  };
  double lo = 0.0, hi = 1e-3 * step;
  constexpr double kMaxSteps = 1e6;  // give up (report +inf) beyond 1e6 steps
  while (S_at(hi) < target) {
    lo = hi;
    hi *= 2.0;
    if (hi > kMaxSteps * step) return kInf;
  }
  for (int it = 0; it < 200 && hi - lo > 1e-12 * hi; ++it) {
    const double mid = 0.5 * (lo + hi);
    (S_at(mid) < target ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

/// Type-7 (linear interpolation) sample quantile of sorted `v`.
double quantile(const std::vector<double>& v, double q) {
  const double h = (static_cast<double>(v.size()) - 1.0) * q;
  const auto i = static_cast<std::size_t>(std::floor(h));
  if (i + 1 >= v.size()) return v.back();
  return v[i] + (h - static_cast<double>(i)) * (v[i + 1] - v[i]);
}

/// Uniform index in [0, n) from one 64-bit draw (modulo; bias < n / 2^64, negligible).
std::size_t draw(std::mt19937_64& rng, std::size_t n) {
  return static_cast<std::size_t>(rng() % static_cast<std::uint64_t>(n));
}

/// Restores the GSL error handler on scope exit (GSL errors become return codes).
struct GslHandlerOff {
  gsl_error_handler_t* old = gsl_set_error_handler_off();
  ~GslHandlerOff() { gsl_set_error_handler(old); }
};

}  // namespace

std::size_t FssDataSet::num_points() const {
  std::size_t n = 0;
  for (const auto& c : curves) n += c.x.size();
  return n;
}

const char* fss_param_name(std::size_t k) {
  static const char* names[] = {"x_c", "a", "b"};
  return k < 3 ? names[k] : "?";
}

FssBootstrapMode fss_bootstrap_mode_from_name(const std::string& name) {
  return core::enum_from_name(name, {FssBootstrapMode::kPoints, FssBootstrapMode::kCurves}, fss_bootstrap_mode_name,
                              "bootstrap mode");
}

const char* fss_bootstrap_mode_name(FssBootstrapMode m) {
  return m == FssBootstrapMode::kPoints ? "points" : "curves";
}

FssDataSet make_fss_dataset(const std::vector<double>& L, const std::vector<double>& x,
                            const std::vector<double>& y, const std::vector<double>& dy) {
  const std::size_t n = x.size();
  if (L.size() != n || y.size() != n || (!dy.empty() && dy.size() != n))
    throw InputError(fmt::format("collapse fss: column lengths differ (L {}, x {}, y {}, dy {})",
                                 L.size(), n, y.size(), dy.size()));
  std::map<double, std::vector<std::size_t>> groups;
  for (std::size_t i = 0; i < n; ++i) {
    const double e = dy.empty() ? 1.0 : dy[i];
    if (!std::isfinite(L[i]) || !std::isfinite(x[i]) || !std::isfinite(y[i]) || !std::isfinite(e))
      throw InputError(fmt::format("collapse fss: row {}: non-finite value", i));
    if (!(L[i] > 0.0))
      throw InputError(fmt::format("collapse fss: row {}: L = {} must be > 0", i, L[i]));
    if (!(e > 0.0))
      throw InputError(fmt::format("collapse fss: row {}: dy = {} must be > 0", i, e));
    groups[L[i]].push_back(i);
  }
  FssDataSet d;
  for (auto& [size, rows] : groups) {
    std::stable_sort(rows.begin(), rows.end(), [&](std::size_t a, std::size_t b) { return x[a] < x[b]; });
    FssCurve c;
    c.L = size;
    for (const std::size_t i : rows) {
      c.x.push_back(x[i]);
      c.y.push_back(y[i]);
      c.dy.push_back(dy.empty() ? 1.0 : dy[i]);
      c.rows.push_back(i);
    }
    d.curves.push_back(std::move(c));
  }
  return d;
}

FssQuality fss_quality(const FssDataSet& data, const FssParams& p, const FssWindow& window,
                       const FssWeights& weights) {
  Scaled s;
  scale(data, p, s);
  return quality_scaled(s, window, weights);
}

std::vector<FssPoint> fss_points(const FssDataSet& data, const FssParams& p,
                                 const FssWindow& window) {
  Scaled s;
  scale(data, p, s);
  std::vector<FssPoint> out;
  out.reserve(data.num_points());
  for (std::size_t c = 0; c < data.curves.size(); ++c) {
    const auto& cv = data.curves[c];
    for (std::size_t i = 0; i < cv.x.size(); ++i) {
      FssPoint q;
      q.curve = c;
      q.index = i;
      q.L = cv.L;
      q.x = cv.x[i];
      q.y = cv.y[i];
      q.dy = cv.dy[i];
      q.x_scaled = s.xs[c][i];
      q.y_scaled = s.ys[c][i];
      q.dy_scaled = s.dys[c][i];
      q.in_window = in_window(window, q.x_scaled);
      double Y, dY2;
      if (master_at(s, {}, c, q.x_scaled, Y, dY2)) {
        q.has_master = true;
        q.Y = Y;
        q.dY = std::sqrt(dY2);
        const double r = q.y_scaled - Y;
        q.term = r * r / (q.dy_scaled * q.dy_scaled + dY2);
      }
      out.push_back(q);
    }
  }
  return out;
}

void FssFitOptions::validate() const {
  for (std::size_t k = 0; k < 3; ++k) {
    if (!std::isfinite(start[k]))
      throw ConfigError(fmt::format("collapse fss: start {} = {} must be finite", fss_param_name(k), start[k]));
    if (!std::isnan(step[k]) && !(step[k] > 0.0 && std::isfinite(step[k])))
      throw ConfigError(fmt::format("collapse fss: step of {} = {} must be > 0", fss_param_name(k), step[k]));
  }
  if (std::isnan(window.lo) || std::isnan(window.hi) || !(window.lo < window.hi))
    throw ConfigError(fmt::format("collapse fss: x window [{}, {}]: need lo < hi", window.lo, window.hi));
  if (!(tolerance > 0.0)) throw ConfigError(fmt::format("collapse fss: tolerance = {} must be > 0", tolerance));
  // Each iteration evaluates S over every pair of curves: the caps bound the run time.
  if (max_iterations < 1 || max_iterations > 1000000)
    throw ConfigError(fmt::format("collapse fss: max_iterations (--max-iterations) = {}: expected 1..1000000",
                                  max_iterations));
  if (max_restarts < 0 || max_restarts > 1000)
    throw ConfigError(fmt::format("collapse fss: max_restarts (--restarts) = {}: expected 0..1000", max_restarts));
  if (bootstrap < 0 || bootstrap > 100000)
    throw ConfigError(fmt::format("collapse fss: bootstrap = {}: expected 0..100000 resamples", bootstrap));
  if (!(ci_level > 0.0 && ci_level < 1.0))
    throw ConfigError(fmt::format("collapse fss: ci level = {} must be in (0, 1)", ci_level));
}

FssFitResult fit_fss_collapse(const FssDataSet& data_in, const FssFitOptions& o) {
  o.validate();
  if (data_in.curves.size() < 2)
    throw NoResultError(fmt::format(
        "collapse fss: need at least two system sizes L, got {}{}", data_in.curves.size(),
        data_in.curves.empty() ? std::string() : fmt::format(" (L = {})", data_in.curves[0].L)));
  const GslHandlerOff gsl_guard;

  FssFitResult res;
  // Default steps.
  double xmin = kInf, xmax = -kInf;
  for (const auto& c : data_in.curves) {
    xmin = std::min(xmin, c.x.front());
    xmax = std::max(xmax, c.x.back());
  }
  const double default_steps[3] = {xmax > xmin ? 0.01 * (xmax - xmin) : 0.01, 0.01, 0.01};
  for (std::size_t k = 0; k < 3; ++k) res.step[k] = std::isnan(o.step[k]) ? default_steps[k] : o.step[k];

  const FssQuality q0 = fss_quality(data_in, o.start, o.window);
  if (q0.n_terms == 0 || !std::isfinite(q0.S))
    throw NoResultError(fmt::format(
        "collapse fss: S is undefined at the start (x_c = {}, a = {}, b = {}): no point with "
        "scaled x in [{}, {}] is bracketed by another size; the sizes do not overlap there "
        "(check --start and --x-window)",
        o.start[0], o.start[1], o.start[2], o.window.lo, o.window.hi));

  MinResult m = minimise(data_in, {}, o, o.start, res.step);
  if (m.S >= kPenalty) throw NoResultError("collapse fss: the minimisation lost every term of S");

  FssDataSet scaled_copy;
  const FssDataSet* data = &data_in;
  if (o.rescale_errors && m.S > 0.0) {
    res.dy_scale = std::sqrt(m.S);
    scaled_copy = data_in;
    for (auto& c : scaled_copy.curves)
      for (auto& e : c.dy) e *= res.dy_scale;
    data = &scaled_copy;
  }
  res.best = m.p;
  res.quality = fss_quality(*data, m.p, o.window);
  res.evaluations = m.evaluations;
  res.restarts = m.restarts;
  res.converged = m.converged;

  res.err_low.fill(core::kUnset);
  res.err_high.fill(core::kUnset);
  res.ci_low.fill(core::kUnset);
  res.ci_high.fill(core::kUnset);
  if (o.s_plus_one) {
    const double target = res.quality.S + 1.0;
    for (std::size_t k = 0; k < 3; ++k) {
      if (o.fixed[k]) continue;
      res.err_low[k] = splus1_side(*data, o.window, res.best, k, -1.0, res.step[k], target);
      res.err_high[k] = splus1_side(*data, o.window, res.best, k, +1.0, res.step[k], target);
    }
  }

  if (o.bootstrap > 0) {
    // Draw every replicate's weights first (sequentially: deterministic), then
    // minimise the replicates in parallel.
    std::mt19937_64 rng(o.seed);
    const std::size_t K = data->curves.size();
    std::vector<FssWeights> reps(static_cast<std::size_t>(o.bootstrap));
    for (auto& w : reps) {
      w.assign(K, {});
      if (o.bootstrap_mode == FssBootstrapMode::kPoints) {
        for (std::size_t c = 0; c < K; ++c) {
          const std::size_t n = data->curves[c].x.size();
          w[c].assign(n, 0.0);
          for (std::size_t j = 0; j < n; ++j) w[c][draw(rng, n)] += 1.0;
        }
      } else {
        std::vector<double> count(K, 0.0);
        for (int attempt = 0; attempt < 1000; ++attempt) {
          std::fill(count.begin(), count.end(), 0.0);
          for (std::size_t j = 0; j < K; ++j) count[draw(rng, K)] += 1.0;
          if (std::count_if(count.begin(), count.end(), [](double v) { return v > 0; }) >= 2) break;
        }
        for (std::size_t c = 0; c < K; ++c) w[c].assign(data->curves[c].x.size(), count[c]);
      }
    }
    std::vector<MinResult> out(reps.size());
    std::vector<char> ok(reps.size(), 0);
#pragma omp parallel for schedule(dynamic)
    for (std::ptrdiff_t r = 0; r < static_cast<std::ptrdiff_t>(reps.size()); ++r) {
      const auto i = static_cast<std::size_t>(r);
      const FssQuality qs = fss_quality(*data, res.best, o.window, reps[i]);
      if (qs.n_terms == 0) continue;
      out[i] = minimise(*data, reps[i], o, res.best, res.step);
      ok[i] = out[i].S < kPenalty ? 1 : 0;
    }
    for (std::size_t i = 0; i < reps.size(); ++i) {
      if (ok[i]) {
        res.bootstrap_samples.push_back(out[i].p);
        ++res.bootstrap_ok;
      } else {
        ++res.bootstrap_failed;
      }
    }
    if (res.bootstrap_ok >= 2) {
      const double tail = 0.5 * (1.0 - o.ci_level);
      for (std::size_t k = 0; k < 3; ++k) {
        if (o.fixed[k]) continue;
        std::vector<double> v;
        for (const auto& p : res.bootstrap_samples) v.push_back(p[k]);
        std::sort(v.begin(), v.end());
        res.ci_low[k] = quantile(v, tail);
        res.ci_high[k] = quantile(v, 1.0 - tail);
      }
    }
  }
  return res;
}

}  // namespace shearzone::fit
