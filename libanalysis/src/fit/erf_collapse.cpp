#include "shearzone/fit/erf_collapse.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

namespace shearzone::fit {

double ErfCollapseResult::width(double N) const {
  if (global.values.size() < 3) return std::nan("");
  return global.values[1] * std::pow(N / n_ref, -global.values[2]);
}

ErfCollapseResult fit_erf_collapse(const std::vector<ErfCollapseGroup>& groups,
                                   const FitOptions& o) {
  ErfCollapseResult res;
  const std::size_t ng = groups.size();
  double lsum = 0.0;
  for (const auto& g : groups) {
    res.per_group.push_back(fit_erf(g.x, g.y, g.sigma, o));
    lsum += std::log(g.N);
  }
  res.n_ref = ng > 0 ? std::exp(lsum / static_cast<double>(ng)) : std::nan("");
  std::vector<double> ns;
  for (const auto& g : groups) ns.push_back(g.N);
  std::sort(ns.begin(), ns.end());
  if (ng < 2 || ns.front() == ns.back()) {
    res.global_status = FitStatus::kTooFewPoints;
    res.global_message = "the global fit needs at least two groups with different N";
    return res;
  }

  // Starting values from the usable per-group fits: phi_c their mean, W0 and α from
  // the line ln W = ln W0 − α ln(N/N_ref).
  std::vector<double> start(3 + 2 * ng);
  double phic = 0, sl = 0, sw = 0, sll = 0, slw = 0;
  int used = 0;
  for (std::size_t g = 0; g < ng; ++g) {
    const auto& c = res.per_group[g];
    std::array<double, 4> s{};
    if (c.usable()) {
      for (int k = 0; k < 4; ++k) s[static_cast<std::size_t>(k)] = c.result.values[static_cast<std::size_t>(k)];
      const double l = std::log(groups[g].N / res.n_ref), w = std::log(s[3]);
      phic += s[2];
      sl += l;
      sw += w;
      sll += l * l;
      slw += l * w;
      ++used;
    } else {
      s = erf_start(groups[g].x, groups[g].y);
    }
    start[3 + 2 * g] = s[0];
    start[4 + 2 * g] = s[1];
  }
  double alpha = 0.0, w0 = 0.0;
  if (used >= 2 && used * sll - sl * sl > 0) {
    const double slope = (used * slw - sl * sw) / (used * sll - sl * sl);
    alpha = -slope;
    w0 = std::exp((sw - slope * sl) / used);
    phic /= used;
  } else {
    std::vector<double> ax, ay;
    for (const auto& g : groups) {
      ax.insert(ax.end(), g.x.begin(), g.x.end());
      ay.insert(ay.end(), g.y.begin(), g.y.end());
    }
    const auto s = erf_start(ax, ay);
    phic = used > 0 ? phic / used : s[2];
    w0 = s[3];
  }
  start[0] = phic;
  start[1] = w0;
  start[2] = alpha;

  Problem pr;
  pr.num_params = static_cast<int>(3 + 2 * ng);
  pr.names = {"phi_c", "W0", "alpha"};
  pr.transforms = {Transform::kIdentity, Transform::kLog, Transform::kIdentity};
  std::vector<std::size_t> gi;
  std::vector<double> xs, lnn;
  for (std::size_t g = 0; g < ng; ++g) {
    pr.names.push_back("rc0_" + groups[g].label);
    pr.names.push_back("rcinf_" + groups[g].label);
    pr.transforms.push_back(Transform::kIdentity);
    pr.transforms.push_back(Transform::kIdentity);
    for (std::size_t i = 0; i < groups[g].x.size(); ++i) {
      gi.push_back(g);
      xs.push_back(groups[g].x[i]);
      pr.y.push_back(groups[g].y[i]);
      pr.sigma.push_back(groups[g].sigma.empty() ? 1.0 : groups[g].sigma[i]);
    }
    lnn.push_back(std::log(groups[g].N / res.n_ref));
  }
  const bool any_sigma = std::any_of(groups.begin(), groups.end(), [](const auto& g) { return !g.sigma.empty(); });
  if (!any_sigma) pr.sigma.clear();
  const int np = pr.num_params;
  pr.model = [gi, xs, lnn, np](int i, const double* p, double* f, double* grad) {
    using D = Dual<5>;
    const std::size_t ii = static_cast<std::size_t>(i);
    const std::size_t g = gi[ii];
    const std::size_t a = 3 + 2 * g;
    const double v[5] = {p[0], p[1], p[2], p[a], p[a + 1]};
    std::array<D, 5> d;
    for (int k = 0; k < 5; ++k) d[static_cast<std::size_t>(k)] = D::variable(v[k], k);
    const D w = d[1] * exp(-d[2] * lnn[g]);
    const D r = d[3] + (d[4] - d[3]) * (0.5 * (1.0 + erf((xs[ii] - d[0]) / w)));
    *f = r.v;
    if (grad) {
      std::fill(grad, grad + np, 0.0);
      grad[0] = r.d[0];
      grad[1] = r.d[1];
      grad[2] = r.d[2];
      grad[a] = r.d[3];
      grad[a + 1] = r.d[4];
    }
    return std::isfinite(r.v);
  };
  if (pr.y.size() <= static_cast<std::size_t>(np)) {
    res.global_status = FitStatus::kTooFewPoints;
    res.global_message = fmt::format("{} points for {} global parameters", pr.y.size(), np);
    return res;
  }
  res.global = solve(pr, start, o);
  if (!res.global.usable || !res.global.converged) {
    res.global_status = FitStatus::kNoConvergence;
    res.global_message = fmt::format("solver: {}: {}", res.global.termination, res.global.message);
  } else if (!res.global.covariance_ok) {
    res.global_status = FitStatus::kSingularCovariance;
    res.global_message = "rank-deficient Jacobian";
  } else {
    res.global_status = FitStatus::kOk;
  }
  return res;
}

}  // namespace shearzone::fit
