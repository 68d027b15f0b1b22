#include "shearzone/profile/radial_profile.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <fmt/format.h>

#include "shearzone/core/conventions.hpp"
#include "shearzone/core/error.hpp"

namespace shearzone::profile {

using core::VectorFlag;

void ProfileOptions::validate() const {
  auto positive = [](const char* what, double v) {
    if (!(std::isfinite(v) && v > 0))
      throw ConfigError(fmt::format("profile: {} = {}: must be a positive number", what, v));
  };
  if (!std::isfinite(centre_x_px) || !std::isfinite(centre_y_px))
    throw ConfigError("profile: the cup centre is not set (give --centre, --detect-cup, or a "
                      "field file with centre_x_px/centre_y_px attributes)");
  positive("m_per_px", m_per_px);
  positive("bin width (m)", bin_m);
  positive("r_max (the cup radius, m)", r_max_m);
  if (!(std::isfinite(r_min_m) && r_min_m >= 0 && r_min_m < r_max_m))
    throw ConfigError(fmt::format("profile: r_min = {} m must satisfy 0 <= r_min < r_max = {} m",
                                  r_min_m, r_max_m));
  if (lockin_harmonics != 0 && !(lockin_harmonics >= 1 && lockin_harmonics <= 31 && lockin_harmonics % 2 == 1))
    throw ConfigError(fmt::format("profile: lock-in harmonics {}: expected 0 (off) or an odd number 1..31",
                                  lockin_harmonics));
  if ((r_max_m - r_min_m) < 0.5 * bin_m)
    throw ConfigError(fmt::format("profile: bin width {} m is more than twice the annulus ({} to {} m); expected a "
                                  "bin that fits",
                                  bin_m, r_min_m, r_max_m));
  if ((r_max_m - r_min_m) / bin_m > 1e5)
    throw ConfigError(fmt::format("profile: bin width {} m gives more than 1e5 bins", bin_m));
}

std::size_t ProfileOptions::num_bins() const {
  // Whole bins, and a last partial one only when it holds its own centre: a sliver past
  // the last whole bin (less than half a bin) would put a row's r_m outside the cup
  // (a 17th row at 0.0345 m for a cup of 0.034 m); its vectors are left out.
  const double n = (r_max_m - r_min_m) / bin_m;
  return std::max<std::size_t>(1, static_cast<std::size_t>(std::floor(n + 0.5 + 1e-9)));
}

double ProfileOptions::bin_centre_m(std::size_t k) const {
  return r_min_m + (static_cast<double>(k) + 0.5) * bin_m;
}

ProfileAccumulator::ProfileAccumulator(ProfileOptions options) : opt_(options) {
  opt_.validate();
  bins_.resize(opt_.num_bins());
  noise_by_bin_.resize(opt_.num_bins());
}

void ProfileAccumulator::add(const core::VectorField& f, double dt_s, int cycle, double phase, double span) {
  const std::size_t n = f.size();
  if (f.u_px.size() != n || f.v_px.size() != n || f.flag.size() != n)
    throw InputError("profile: field arrays do not match the grid");
  core::to_points(f, points_);
  add(points_, dt_s, cycle, phase, span);
}

void ProfileAccumulator::add(const core::PointVectors& p, double dt_s, int cycle, double phase, double span) {
  if (!(std::isfinite(dt_s) && dt_s > 0))
    throw InputError(fmt::format("profile: pair time step {} s: expected a positive number", dt_s));
  const std::size_t n = p.size();
  if (p.y_px.size() != n || p.u_px.size() != n || p.v_px.size() != n || p.flag.size() != n)
    throw InputError("profile: point arrays differ in length");
  const std::size_t nb = bins_.size();
  pair_cycle_.push_back(cycle);
  pair_phase_.push_back(phase);
  pair_span_.push_back(std::isfinite(span) ? span : 0.0);
  pair_s_.resize(pair_s_.size() + nb, 0.0);
  pair_st_.resize(pair_st_.size() + nb, 0.0);
  pair_n_.resize(pair_n_.size() + nb, 0.0);
  double* ps = pair_s_.data() + n_pairs_ * nb;
  double* pst = pair_st_.data() + n_pairs_ * nb;
  double* pn = pair_n_.data() + n_pairs_ * nb;
  const double scale = opt_.m_per_px / dt_s;  // px per pair -> m/s
  // This pair's moments per bin of v_theta and dr (radius - bin centre) for the fluctuation.
  struct Moments {
    double n = 0, d = 0, dd = 0, v = 0, vv = 0, vd = 0;
  };
  std::vector<Moments> mom(nb);
  for (std::size_t k = 0; k < n; ++k) {
    const double x = p.x_px[k], y = p.y_px[k];
    const double r_m = std::hypot(x - opt_.centre_x_px, y - opt_.centre_y_px) * opt_.m_per_px;
    if (!(r_m >= opt_.r_min_m && r_m < opt_.r_max_m)) continue;
    const auto b = static_cast<std::size_t>((r_m - opt_.r_min_m) / opt_.bin_m);
    if (b >= bins_.size()) continue;
    const VectorFlag fl = p.flag[k];
    if (fl == VectorFlag::kMasked) {
      ++bins_[b].masked;
      continue;
    }
    if (fl == VectorFlag::kInvalid || (opt_.exclude_replaced && fl == VectorFlag::kReplaced)) {
      ++bins_[b].invalid;
      continue;
    }
    if (fl == VectorFlag::kReplaced) ++replaced_used_;
    const double u = p.u_px[k] * scale, v = p.v_px[k] * scale;
    const auto pc = core::polar_from_cartesian(x, y, u, v, opt_.centre_x_px, opt_.centre_y_px);
    const double a = std::hypot(u, v);
    Sums& s = bins_[b];
    s.s_abs += a;
    s.s_abs2 += a * a;
    s.s_theta += pc.v_theta;
    s.s_r += pc.v_r;
    const double dr = r_m - opt_.bin_centre_m(b);
    s.s_dr += dr;
    s.s_dr2 += dr * dr;
    Moments& mo = mom[b];
    mo.n += 1;
    mo.d += dr;
    mo.dd += dr * dr;
    mo.v += pc.v_theta;
    mo.vv += pc.v_theta * pc.v_theta;
    mo.vd += pc.v_theta * dr;
    ++s.n;
    ps[b] += a;
    pst[b] += pc.v_theta;
    pn[b] += 1.0;
    NoiseSums& ns = noise_by_bin_[b];
    ns.s += pc.v_r;
    ns.s2 += pc.v_r * pc.v_r;
    ++ns.n;
  }
  // Residual sum of squares of v_theta about the pair's least-squares line in dr.
  for (std::size_t b = 0; b < nb; ++b) {
    const Moments& mo = mom[b];
    if (mo.n < 3) continue;
    const double svv = mo.vv - mo.v * mo.v / mo.n, sdd = mo.dd - mo.d * mo.d / mo.n, svd = mo.vd - mo.v * mo.d / mo.n;
    const bool slope = sdd > 1e-12 * mo.dd + std::numeric_limits<double>::min();
    bins_[b].fluct_ss += std::max(0.0, slope ? svv - svd * svd / sdd : svv);
    bins_[b].fluct_dof += slope ? mo.n - 2 : mo.n - 1;
  }
  ++n_pairs_;
}

RadialProfile ProfileAccumulator::finish_common() const {
  RadialProfile p;
  p.n_pairs = n_pairs_;
  p.n_replaced_used = replaced_used_;
  p.bins.resize(bins_.size());
  const std::size_t nb = bins_.size();
  p.pairs.n_bins = nb;
  p.pairs.cycle = pair_cycle_;
  p.pairs.phase = pair_phase_;
  p.pairs.phase_span = pair_span_;
  p.pairs.n_vectors = pair_n_;
  p.pairs.v_abs.assign(pair_s_.size(), 0.0);
  p.pairs.v_theta.assign(pair_s_.size(), 0.0);
  for (std::size_t i = 0; i < pair_s_.size(); ++i)
    if (pair_n_[i] > 0) {
      p.pairs.v_abs[i] = pair_s_[i] / pair_n_[i];
      p.pairs.v_theta[i] = pair_st_[i] / pair_n_[i];
    }
  p.grouping = choose_grouping(p.pairs, opt_.grouping);
  const BinMeanBootstrap boot(p.pairs, p.grouping);
  p.n_groups = boot.units();
  p.rho = boot.rho();
  const std::vector<double> se = boot.standard_errors(opt_.se_replicates, opt_.seed);
  for (std::size_t b = 0; b < nb; ++b) {
    const Sums& s = bins_[b];
    ProfileBin& o = p.bins[b];
    o.r_m = opt_.bin_centre_m(b);
    o.n_vectors = s.n;
    o.n_masked = s.masked;
    o.n_invalid = s.invalid;
    if (s.n == 0) continue;
    const double n = static_cast<double>(s.n);
    o.v_abs = s.s_abs / n;
    o.v_theta = s.s_theta / n;
    o.v_r = s.s_r / n;
    o.v_abs_rms = std::sqrt(s.s_abs2 / n);
    o.v_abs_sem = se[b];
    const double dr = s.s_dr / n;
    o.r_vectors_mean_m = o.r_m + dr;
    o.r_vectors_sd_m = std::sqrt(std::max(0.0, s.s_dr2 / n - dr * dr));
    if (s.fluct_dof > 0) o.dv_theta = std::sqrt(s.fluct_ss / s.fluct_dof);
  }
  if (opt_.lockin_harmonics > 0 && n_pairs_ > 0 && p.pairs.phase_known()) {
    const LockinFit fit(p.pairs, opt_.lockin_harmonics);
    p.lockin = true;
    p.lockin_harmonics = fit.harmonics();
    p.lockin_clusters = fit.cluster_kind();
    p.lockin_n_clusters = fit.clusters();
    p.lockin_block_pairs = fit.block_pairs();
    p.lockin_rho = fit.rho();
    for (std::size_t b = 0; b < nb; ++b) p.bins[b].lockin = fit.bins()[b];
  }
  return p;
}

RadialProfile ProfileAccumulator::finish_with_region_noise(double lo_m, double hi_m) const {
  RadialProfile p = finish_common();
  NoiseSums t;
  for (std::size_t b = 0; b < bins_.size(); ++b) {
    const double r = opt_.bin_centre_m(b);
    if (r < lo_m || r > hi_m) continue;
    const NoiseSums& s = noise_by_bin_[b];
    t.s += s.s;
    t.s2 += s.s2;
    t.n += s.n;
  }
  if (t.n < 2)
    throw NoResultError(fmt::format(
        "profile: no usable vector in the noise region {:.6g} <= r <= {:.6g} m (bin centres); give "
        "--noise-region-m inside the measured annulus or a static --noise-ref",
        lo_m, hi_m));
  const double n = static_cast<double>(t.n);
  p.noise_sigma_m_per_s = std::sqrt(std::max(0.0, (t.s2 - t.s * t.s / n) / (n - 1)));
  const double floor = p.noise_sigma_m_per_s * std::sqrt(std::numbers::pi / 2.0);
  for (auto& b : p.bins) b.v_noise = floor;
  return p;
}

RadialProfile ProfileAccumulator::finish_with_reference_noise(const ProfileAccumulator& ref) const {
  RadialProfile p = finish_common();
  const RadialProfile r = ref.finish_common();
  double s = 0;
  std::size_t n = 0;
  for (const auto& b : r.bins) {
    if (b.n_vectors == 0) continue;
    s += b.v_abs * static_cast<double>(b.n_vectors);
    n += b.n_vectors;
  }
  if (n == 0)
    throw NoResultError("profile: the static reference has no usable vector in the annulus");
  const double overall = s / static_cast<double>(n);
  for (std::size_t b = 0; b < p.bins.size(); ++b) {
    // Same bins when the options match; otherwise look the radius up.
    const double rm = p.bins[b].r_m;
    const ProfileBin* match = nullptr;
    for (const auto& rb : r.bins)
      if (std::abs(rb.r_m - rm) <= 0.5 * ref.options().bin_m) {
        match = &rb;
        break;
      }
    p.bins[b].v_noise = match && match->n_vectors > 0 ? match->v_abs : overall;
  }
  p.noise_sigma_m_per_s = overall / std::sqrt(std::numbers::pi / 2.0);
  return p;
}

RadialProfile ProfileAccumulator::finish_with_known_noise(double sigma_m_per_s) const {
  if (!(sigma_m_per_s >= 0.0) || !std::isfinite(sigma_m_per_s))
    throw ConfigError(fmt::format("profile: known noise {} m/s: expected a finite value >= 0", sigma_m_per_s));
  RadialProfile p = finish_common();
  p.noise_sigma_m_per_s = sigma_m_per_s;
  for (auto& b : p.bins) b.v_noise = sigma_m_per_s * std::sqrt(std::numbers::pi / 2.0);
  return p;
}

CyclePhase cycle_phase(double t_s, double f_Hz, double t0_s) {
  const double c = (t_s - t0_s) * f_Hz;
  if (!(std::abs(c) < 1e9))
    throw InputError(fmt::format("time {} s is {} cycles of {} Hz from t0 = {} s: expected fewer than 1e9",
                                 t_s, c, f_Hz, t0_s));
  const double fl = std::floor(c);
  return {static_cast<int>(fl), 360.0 * (c - fl)};
}

}  // namespace shearzone::profile
