#include "shearzone/profile/width.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <random>

#include <fmt/format.h>
#include <gsl/gsl_cdf.h>

#include "shearzone/core/error.hpp"
#include "shearzone/core/stats.hpp"

namespace shearzone::profile {

const char* width_status_name(WidthStatus s) {
  switch (s) {
    case WidthStatus::kOk: return "ok";
    case WidthStatus::kNeverBelow: return "never_below";
    case WidthStatus::kBelowAtVane: return "below_at_vane";
    case WidthStatus::kNoiseLimited: return "noise_limited";
  }
  return "?";
}

void WidthOptions::validate() const {
  if (!(std::isfinite(v_c_m_per_s) && v_c_m_per_s > 0))
    throw ConfigError(fmt::format("width: v_c = {} m/s: must be positive", v_c_m_per_s));
  if (!(noise_factor >= 0)) throw ConfigError("width: noise factor must be >= 0");
  if (bootstrap < 0 || bootstrap > 1000000)
    throw ConfigError(fmt::format("width: bootstrap = {}: expected 0..1000000", bootstrap));
  if (!(confidence > 0 && confidence < 1))
    throw ConfigError(fmt::format("width: confidence {}: expected 0 < c < 1", confidence));
}

WidthInput WidthInput::from_profile(const RadialProfile& p, double R_m) {
  WidthInput w;
  for (const auto& b : p.bins) {
    w.r_m.push_back(b.r_m);
    w.v_abs.push_back(b.v_abs);
    w.n_vectors.push_back(b.n_vectors);
    w.v_noise.push_back(b.v_noise);
  }
  w.R_m = R_m;
  w.pairs = p.pairs;
  w.grouping = p.grouping;
  return w;
}

double scan_rc(const std::vector<double>& r, const std::vector<double>& v,
               const std::vector<std::size_t>& n, double v_c, double R_m, WidthStatus& status) {
  bool have_prev = false;
  double r_prev = 0, v_prev = 0;
  for (std::size_t k = 0; k < r.size(); ++k) {
    if (n[k] == 0) continue;
    if (v[k] < v_c) {
      if (!have_prev) {
        status = WidthStatus::kBelowAtVane;
        return r[k];
      }
      status = WidthStatus::kOk;
      // Linear interpolation between (r_prev, v_prev >= v_c) and (r_k, v_k < v_c).
      return r_prev + (v_prev - v_c) / (v_prev - v[k]) * (r[k] - r_prev);
    }
    have_prev = true;
    r_prev = r[k];
    v_prev = v[k];
  }
  status = WidthStatus::kNeverBelow;
  return R_m;
}

WidthResult shear_zone_width(const WidthInput& in, const WidthOptions& opt) {
  opt.validate();
  const std::size_t nb = in.r_m.size();
  if (nb == 0 || in.v_abs.size() != nb || in.n_vectors.size() != nb)
    throw InputError("width: the profile has no bins");
  WidthResult res;
  res.rc_m = scan_rc(in.r_m, in.v_abs, in.n_vectors, opt.v_c_m_per_s, in.R_m, res.status);
  std::vector<double> noise;
  for (std::size_t k = 0; k < nb; ++k)
    if (in.n_vectors[k] > 0 && k < in.v_noise.size()) noise.push_back(in.v_noise[k]);
  res.v_noise_m_per_s = noise.empty() ? 0.0 : core::percentile(noise, 0.5);
  if (opt.v_c_m_per_s < opt.noise_factor * res.v_noise_m_per_s) res.status = WidthStatus::kNoiseLimited;

  if (opt.bootstrap == 0 || in.grouping == Grouping::kNone || in.pairs.num_pairs() < 2) return res;
  if (in.pairs.n_bins != nb)
    throw InputError(fmt::format("width: the per-pair means have {} bins, the profile {}",
                                 in.pairs.n_bins, nb));
  const BinMeanBootstrap boot(in.pairs, in.grouping);
  res.grouping = boot.grouping();
  res.bootstrap_units = boot.units();
  res.rho = boot.rho();
  std::mt19937_64 rng(opt.seed);
  std::vector<double> rcs, v, nd;
  std::vector<std::size_t> n(nb);
  rcs.reserve(static_cast<std::size_t>(opt.bootstrap));
  WidthStatus st;
  for (int b = 0; b < opt.bootstrap; ++b) {
    boot.draw(rng, v, nd);
    for (std::size_t k = 0; k < nb; ++k) n[k] = static_cast<std::size_t>(nd[k]);
    rcs.push_back(scan_rc(in.r_m, v, n, opt.v_c_m_per_s, in.R_m, st));
  }
  const double a = 0.5 * (1.0 - opt.confidence);
  if (res.grouping == Grouping::kCycles) {
    // Few cycles: the bootstrap spread underestimates the sampling spread by
    // sqrt((G-1)/G) and the normal quantile is too small for G - 1 degrees of
    // freedom; widen the replicates about r_c by sqrt(G/(G-1)) t_(G-1)/z.
    const double G = static_cast<double>(res.bootstrap_units);
    const double f = std::sqrt(G / (G - 1.0)) * gsl_cdf_tdist_Qinv(a, G - 1.0) / gsl_cdf_ugaussian_Qinv(a);
    for (double& x : rcs) x = res.rc_m + f * (x - res.rc_m);
  }
  res.ci_low_m = core::percentile(rcs, a);
  res.ci_high_m = core::percentile(rcs, 1.0 - a);
  return res;
}

}  // namespace shearzone::profile
