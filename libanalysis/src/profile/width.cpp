#include "shearzone/profile/width.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <random>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"

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
    w.v_abs_sem.push_back(b.v_abs_sem);
    w.n_vectors.push_back(b.n_vectors);
    w.v_noise.push_back(b.v_noise);
  }
  w.R_m = R_m;
  w.groups = p.groups;
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

namespace {

double percentile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  const double pos = q * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(pos));
  const std::size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (pos - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

}  // namespace

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
  res.v_noise_m_per_s = noise.empty() ? 0.0 : percentile(noise, 0.5);
  if (opt.v_c_m_per_s < opt.noise_factor * res.v_noise_m_per_s) res.status = WidthStatus::kNoiseLimited;

  res.ci_low_m = res.ci_high_m = res.rc_m;
  if (opt.bootstrap == 0) return res;
  std::mt19937_64 rng(opt.seed);
  std::vector<double> rcs;
  rcs.reserve(static_cast<std::size_t>(opt.bootstrap));
  // Groups: [group index] -> per-bin (mean, n).
  std::map<int, std::vector<std::pair<double, std::size_t>>> by_group;
  for (const auto& g : in.groups) {
    if (g.bin >= nb) continue;
    auto& row = by_group[g.group];
    if (row.empty()) row.assign(nb, {0.0, 0});
    row[g.bin] = {g.v_abs, g.n_vectors};
  }
  std::vector<const std::vector<std::pair<double, std::size_t>>*> groups;
  for (const auto& kv : by_group) groups.push_back(&kv.second);
  std::vector<double> v(nb);
  std::vector<std::size_t> n(nb);
  WidthStatus st;
  if (groups.size() >= 2) {
    res.bootstrap_groups = static_cast<int>(groups.size());
    std::uniform_int_distribution<std::size_t> pick(0, groups.size() - 1);
    std::vector<double> s(nb);
    for (int b = 0; b < opt.bootstrap; ++b) {
      std::fill(s.begin(), s.end(), 0.0);
      std::fill(n.begin(), n.end(), 0);
      for (std::size_t g = 0; g < groups.size(); ++g) {
        const auto& row = *groups[pick(rng)];
        for (std::size_t k = 0; k < nb; ++k) {
          s[k] += row[k].first * static_cast<double>(row[k].second);
          n[k] += row[k].second;
        }
      }
      for (std::size_t k = 0; k < nb; ++k) v[k] = n[k] ? s[k] / static_cast<double>(n[k]) : 0.0;
      rcs.push_back(scan_rc(in.r_m, v, n, opt.v_c_m_per_s, in.R_m, st));
    }
  } else {
    // One group: parametric bootstrap of the bin means from their standard errors.
    if (in.v_abs_sem.size() != nb) return res;
    std::normal_distribution<double> z(0.0, 1.0);
    for (int b = 0; b < opt.bootstrap; ++b) {
      for (std::size_t k = 0; k < nb; ++k) v[k] = in.v_abs[k] + in.v_abs_sem[k] * z(rng);
      rcs.push_back(scan_rc(in.r_m, v, in.n_vectors, opt.v_c_m_per_s, in.R_m, st));
    }
  }
  const double a = 0.5 * (1.0 - opt.confidence);
  res.ci_low_m = percentile(rcs, a);
  res.ci_high_m = percentile(rcs, 1.0 - a);
  return res;
}

}  // namespace shearzone::profile
