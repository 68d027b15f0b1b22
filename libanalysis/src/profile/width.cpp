#include "shearzone/profile/width.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>

#include <fmt/format.h>
#include <gsl/gsl_cdf.h>

#include "shearzone/core/enum_names.hpp"
#include "shearzone/core/error.hpp"
#include "shearzone/core/stats.hpp"
#include "shearzone/profile/lockin.hpp"

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

const char* estimator_name(Estimator e) {
  switch (e) {
    case Estimator::kMeanAbs: return "mean_abs";
    case Estimator::kLockin: return "lockin";
    case Estimator::kAuto: return "auto";
  }
  return "?";
}

Estimator estimator_from_name(const std::string& name) {
  const std::string snake = name == "mean-abs" ? "mean_abs" : name;  // the option's spelling
  if (const auto e = core::enum_named(snake, {Estimator::kMeanAbs, Estimator::kLockin, Estimator::kAuto},
                                      estimator_name))
    return *e;
  throw ConfigError(fmt::format("--estimator {}: expected mean-abs, lockin or auto", name));
}

bool WidthInput::has_lockin() const {
  if (v_abs_lockin.size() != r_m.size() || v_noise_lockin.size() != r_m.size()) return false;
  return std::any_of(v_abs_lockin.begin(), v_abs_lockin.end(), [](double v) { return std::isfinite(v); });
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

void WidthInput::add_bin(double r, double v_abs_bin, std::size_t n, double v_noise_bin) {
  r_m.push_back(r);
  v_abs.push_back(v_abs_bin);
  n_vectors.push_back(n);
  v_noise.push_back(v_noise_bin);
}

WidthInput WidthInput::from_profile(const RadialProfile& p, double R_m) {
  WidthInput w;
  for (const auto& b : p.bins) {
    w.add_bin(b.r_m, b.v_abs, b.n_vectors, b.v_noise);
    w.radii.mean_m.push_back(b.r_vectors_mean_m);
    w.radii.sd_m.push_back(b.r_vectors_sd_m);
  }
  w.R_m = R_m;
  w.pairs = p.pairs;
  w.grouping = p.grouping;
  if (p.lockin) {
    w.lockin_harmonics = p.lockin_harmonics;
    for (const auto& b : p.bins) {
      const bool ok = b.lockin.ok && std::isfinite(b.lockin.v_noise);
      w.v_abs_lockin.push_back(ok ? b.lockin.v_abs : kNoValue);
      w.v_noise_lockin.push_back(ok ? b.lockin.v_noise : kNoValue);
    }
  }
  return w;
}

namespace {

/// The crossing of v_c between two bins whose vectors lie at mean radii r0 < r1 with
/// spreads s0, s1 and whose means v0 >= v_c > v1 > 0. For v = A exp(-r / lambda) a bin
/// mean is A exp(-rbar / lambda) E[exp(-(r - rbar) / lambda)], the last factor
/// exp(s^2 / (2 lambda^2)) to second order: lambda solves
/// lambda = (r1 - r0) / (ln v0 - ln v1 - (s0^2 - s1^2) / (2 lambda^2)) (fixed point from the
/// uncorrected slope). False when it does not settle (the two bins then fall back to
/// the centres).
bool crossing_from_radii(double r0, double s0, double v0, double r1, double s1, double v1, double v_c,
                         double& rc, double& bound, double& lambda_out) {
  if (!(r1 > r0 && s0 >= 0 && s1 >= 0)) return false;
  double lambda = (r1 - r0) / std::log(v0 / v1);
  double a0 = std::log(v0), a1 = std::log(v1);
  for (int it = 0; it < 50; ++it) {
    a0 = std::log(v0) - s0 * s0 / (2 * lambda * lambda);
    a1 = std::log(v1) - s1 * s1 / (2 * lambda * lambda);
    if (!(a0 > a1)) return false;
    const double next = (r1 - r0) / (a0 - a1);
    const bool settled = std::abs(next - lambda) <= 1e-12 * lambda;
    lambda = next;
    if (settled) {
      rc = std::max(r0, r0 + lambda * (a0 - std::log(v_c)));
      lambda_out = lambda;
      const double s = std::max(s0, s1);
      bound = s * s * s * s / (20 * lambda * lambda * lambda);
      return std::isfinite(rc) && std::isfinite(bound);
    }
  }
  return false;
}

}  // namespace

double scan_rc(const std::vector<double>& r, const std::vector<double>& v,
               const std::vector<std::size_t>& n, double v_c, double R_m, WidthStatus& status,
               double* bin_bound_m, const VectorRadii& radii, double* lambda_m) {
  if (bin_bound_m) *bin_bound_m = 0.0;
  if (lambda_m) *lambda_m = 0.0;
  if (radii.known() && (radii.mean_m.size() != r.size() || radii.sd_m.size() != r.size()))
    throw InternalError("scan_rc: the vectors' radii do not match the bins");
  bool have_prev = false;
  std::size_t k_prev = 0;
  double r_prev = 0, v_prev = 0;
  for (std::size_t k = 0; k < r.size(); ++k) {
    if (n[k] == 0) continue;
    if (v[k] < v_c) {
      if (!have_prev) {
        status = WidthStatus::kBelowAtVane;
        return r[k];
      }
      status = WidthStatus::kOk;
      if (!(v[k] > 0 && v_c > 0 && v_prev > v[k])) {
        // Linear interpolation between (r_prev, v_prev >= v_c) and (r_k, v_k < v_c).
        return r_prev + (v_prev - v_c) / (v_prev - v[k]) * (r[k] - r_prev);
      }
      if (radii.known()) {
        double rc = 0, bound = 0, lambda = 0;
        if (crossing_from_radii(radii.mean_m[k_prev], radii.sd_m[k_prev], v_prev, radii.mean_m[k], radii.sd_m[k],
                                v[k], v_c, rc, bound, lambda)) {
          if (bin_bound_m) *bin_bound_m = bound;
          if (lambda_m) *lambda_m = lambda;
          return rc;
        }
      }
      // |v| decays about exponentially across a shear zone's edge: interpolate ln v,
      // exact for v = A exp(-r / lambda) where the linear interpolation of v reads up
      // to dr^2 / (8 lambda) high (0.09 mm for 1.2 mm bins, lambda = 2 mm).
      const double lambda = (r[k] - r_prev) / std::log(v_prev / v[k]);
      // A bin holds the mean over the radii of its vectors, not the value at its centre:
      // for radii spread evenly over a bin of width D, exp(-r / lambda) reads sinh(x) / x
      // high (x = D / (2 lambda)), r_c lambda ln(sinh(x) / x) out, which is taken off; radii
      // spread unevenly (a coarse grid) move it either way by about as much: the bound.
      double bin_bias = 0;
      const double D = k == k_prev + 1 ? r[k] - r_prev : 0.0;
      const double x = 0.5 * D / lambda;
      if (x > 1e-6 && x < 20) bin_bias = lambda * std::log(std::sinh(x) / x);
      if (bin_bound_m) *bin_bound_m = bin_bias;
      if (lambda_m) *lambda_m = lambda;
      return std::max(r_prev, r_prev + lambda * std::log(v_prev / v_c) - bin_bias);
    }
    have_prev = true;
    k_prev = k;
    r_prev = r[k];
    v_prev = v[k];
  }
  status = WidthStatus::kNeverBelow;
  return R_m;
}

BiasShift velocity_bias_shift(double bias_m_per_s, double v_c, double lambda_m, double rc_m, double r_first_m) {
  BiasShift s;
  if (!(bias_m_per_s > 0 && v_c > 0 && lambda_m > 0)) return s;
  const double e = bias_m_per_s / v_c;
  s.out_m = lambda_m * std::log1p(e);
  const double to_first_bin = std::max(0.0, rc_m - r_first_m);  // no farther in than that
  s.in_m = e < 1 ? std::min(-lambda_m * std::log1p(-e), to_first_bin) : to_first_bin;
  return s;
}

double resolution_bound_m(double footprint_var_m2, double lambda_m) {
  return footprint_var_m2 > 0 && lambda_m > 0 ? footprint_var_m2 / (2 * lambda_m) : 0.0;
}

namespace {

/// The interval factor for G clusters: t_(G-1) / z at the level's tail a.
double small_sample_factor(double a, double G) {
  return gsl_cdf_tdist_Qinv(a, G - 1.0) / gsl_cdf_ugaussian_Qinv(a);
}

/// The interval's ends from the sampling replicates and the binning's bound b (scan_rc):
/// a systematic error known only to lie within +-b, combined with the sampling half-width
/// h of each side as a rectangular distribution (standard deviation b/sqrt(3); GUM, JCGM
/// 100:2008, 4.3.7 and 5.1.2): h' = sqrt(h^2 + z^2 b^2 / 3), z the normal quantile of
/// the level (1.96 at 95 %). The velocities' bias bound enters the same way, each side
/// by how far it moves r_c that way (res.velocity_bias). The footprint's bias
/// (res.resolution_bound_m) only moves r_c outwards: it is added to the low side alone,
/// in quadrature. Through the whole chain (docs/profile-width.md, 200 clips) the
/// intervals held the truth in all of them.
void set_interval(WidthResult& res, const std::vector<double>& rcs, double a, double b) {
  const double z = gsl_cdf_ugaussian_Qinv(a);
  const double lo = std::max(0.0, res.rc_m - core::percentile(rcs, a));
  const double hi = std::max(0.0, core::percentile(rcs, 1.0 - a) - res.rc_m);
  // The truth lies below r_c by what moved it outwards (a velocity read high) and above
  // by what moved it inwards.
  const double below = res.velocity_bias.out_m, above = res.velocity_bias.in_m;
  const double m = res.resolution_bound_m;
  res.ci_low_m = res.rc_m - std::sqrt(lo * lo + z * z * (b * b + below * below) / 3.0 + m * m);
  res.ci_high_m = res.rc_m + std::sqrt(hi * hi + z * z * (b * b + above * above) / 3.0);
}

/// The bounds of the systematic errors at the crossing (ok status only).
void set_systematic_bounds(WidthResult& res, const WidthInput& in, double v_c, double lambda) {
  if (res.status != WidthStatus::kOk) return;
  res.resolution_bound_m = resolution_bound_m(in.footprint_var_m2, lambda);
  res.velocity_bias = velocity_bias_shift(in.velocity_bias_m_per_s, v_c, lambda, res.rc_m, in.r_m.front());
}

WidthResult lockin_width(const WidthInput& in, const WidthOptions& opt) {
  const std::size_t nb = in.r_m.size();
  WidthResult res;
  res.estimator = Estimator::kLockin;
  // Bins without a lock-in value are skipped like empty bins.
  std::vector<std::size_t> n(nb, 0);
  for (std::size_t k = 0; k < nb; ++k) n[k] = std::isfinite(in.v_abs_lockin[k]) ? 1 : 0;
  double bin_bound = 0, lambda = 0;
  res.rc_m = scan_rc(in.r_m, in.v_abs_lockin, n, opt.v_c_m_per_s, in.R_m, res.status, &bin_bound, in.radii, &lambda);
  set_systematic_bounds(res, in, opt.v_c_m_per_s, lambda);
  // The floor where the decision was made.
  std::vector<std::size_t> idx;
  for (std::size_t k = 0; k < nb; ++k)
    if (n[k]) idx.push_back(k);
  double floor = 0;
  if (res.status == WidthStatus::kNeverBelow) floor = in.v_noise_lockin[idx.back()];
  else if (res.status == WidthStatus::kBelowAtVane) floor = in.v_noise_lockin[idx.front()];
  else
    for (std::size_t i = 1; i < idx.size(); ++i)
      if (in.v_abs_lockin[idx[i]] < opt.v_c_m_per_s) {  // the crossing scan_rc took
        floor = std::max(in.v_noise_lockin[idx[i - 1]], in.v_noise_lockin[idx[i]]);
        break;
      }
  res.v_noise_m_per_s = floor;
  if (opt.v_c_m_per_s < opt.noise_factor * floor) res.status = WidthStatus::kNoiseLimited;

  const bool have_series = in.pairs.num_pairs() >= 2 && in.pairs.phase_known() &&
                           in.pairs.v_theta.size() == in.pairs.num_pairs() * nb && in.lockin_harmonics > 0;
  if (opt.bootstrap == 0 || !have_series) return res;
  if (in.pairs.n_bins != nb)
    throw InputError(fmt::format("width: the per-pair means have {} bins, the profile {}", in.pairs.n_bins, nb));
  const LockinFit fit(in.pairs, in.lockin_harmonics);
  if (fit.clusters() < 2) return res;
  res.grouping = fit.block_pairs() == 0 ? Grouping::kCycles : Grouping::kPairs;
  res.bootstrap_units = fit.clusters();
  res.rho = fit.rho();
  std::mt19937_64 rng(opt.seed);
  std::vector<double> rcs, v;
  rcs.reserve(static_cast<std::size_t>(opt.bootstrap));
  WidthStatus st;
  for (int b = 0; b < opt.bootstrap; ++b) {
    fit.draw(rng, v);
    // Keep the profile's bins: a bin without a value stays skipped.
    for (std::size_t k = 0; k < nb; ++k)
      if (!n[k]) v[k] = kNoValue;
    rcs.push_back(scan_rc(in.r_m, v, n, opt.v_c_m_per_s, in.R_m, st, nullptr, in.radii));
  }
  const double a = 0.5 * (1.0 - opt.confidence);
  const double f = small_sample_factor(a, static_cast<double>(res.bootstrap_units));
  for (double& x : rcs) x = res.rc_m + f * (x - res.rc_m);
  // The binning's own bias (scan_rc) is not sampling noise: combined with it (set_interval).
  if (!opt.widen_by_binning) bin_bound = 0;
  set_interval(res, rcs, a, bin_bound);
  return res;
}

WidthResult mean_abs_width(const WidthInput& in, const WidthOptions& opt);

}  // namespace

WidthResult shear_zone_width(const WidthInput& in, const WidthOptions& opt) {
  opt.validate();
  const std::size_t nb = in.r_m.size();
  if (nb == 0 || in.v_abs.size() != nb || in.n_vectors.size() != nb)
    throw InputError("width: the profile has no bins");
  if (opt.estimator == Estimator::kLockin) {
    if (!in.has_lockin())
      throw InputError("width: the profile has no lock-in values (the drive frequency was unknown to `shearzone "
                       "profile`, or it ran with --lockin-harmonics 0 or a phase window); use --estimator mean-abs");
    return lockin_width(in, opt);
  }
  WidthResult res = mean_abs_width(in, opt);
  if (opt.estimator == Estimator::kAuto && res.status == WidthStatus::kNoiseLimited && in.has_lockin())
    return lockin_width(in, opt);
  return res;
}

namespace {

WidthResult mean_abs_width(const WidthInput& in, const WidthOptions& opt) {
  const std::size_t nb = in.r_m.size();
  if (nb == 0 || in.v_abs.size() != nb || in.n_vectors.size() != nb)
    throw InputError("width: the profile has no bins");
  WidthResult res;
  double bin_bound = 0, lambda = 0;
  res.rc_m = scan_rc(in.r_m, in.v_abs, in.n_vectors, opt.v_c_m_per_s, in.R_m, res.status, &bin_bound, in.radii, &lambda);
  set_systematic_bounds(res, in, opt.v_c_m_per_s, lambda);
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
    rcs.push_back(scan_rc(in.r_m, v, n, opt.v_c_m_per_s, in.R_m, st, nullptr, in.radii));
  }
  const double a = 0.5 * (1.0 - opt.confidence);
  if (res.grouping == Grouping::kCycles) {
    // Few cycles: the bootstrap spread underestimates the sampling spread by
    // sqrt((G-1)/G) and the normal quantile is too small for G - 1 degrees of
    // freedom; widen the replicates about r_c by sqrt(G/(G-1)) t_(G-1)/z.
    const double G = static_cast<double>(res.bootstrap_units);
    const double f = std::sqrt(G / (G - 1.0)) * small_sample_factor(a, G);
    for (double& x : rcs) x = res.rc_m + f * (x - res.rc_m);
  }
  // The binning's own bias (scan_rc) is not sampling noise: combined with it (set_interval).
  if (!opt.widen_by_binning) bin_bound = 0;
  set_interval(res, rcs, a, bin_bound);
  return res;
}

}  // namespace

}  // namespace shearzone::profile
