#include "shearzone/pipeline/width_job.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/core/unset.hpp"
#include "shearzone/io/atomic_output.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/io/profile_csv.hpp"
#include "shearzone/profile/width_input.hpp"

namespace shearzone::pipeline {

namespace {

using io::format_number;

}  // namespace

void WidthJobOptions::validate() const {
  if (inputs.empty()) throw ConfigError("width: no profile given");
  width.validate();
  for (const auto& [k, v] : tags)
    if (k != "N" && k != "phi0_rad")
      throw ConfigError(fmt::format("--tag {}={}: only N and phi0_rad are width columns", k, v));
}

std::vector<WidthRow> run_width_job(const WidthJobOptions& o, const core::Metadata& header) {
  o.validate();
  io::check_output_allowed(o.output, o.force);
  const profile::WidthOptions& wo = o.width;

  struct Row {
    std::string label, N, phi0;
    profile::WidthResult res;
    std::string n_pairs;
  };
  std::vector<Row> rows;
  std::vector<WidthRow> report;
  for (const auto& path : o.inputs) {
    const io::ProfileCsv p = io::read_profile_csv(path);
    if (wo.estimator == profile::Estimator::kLockin && !p.has_lockin)
      throw InputError(fmt::format("{}: the profile has no lock-in values (lockin: {}); use --estimator mean-abs or "
                                   "auto, or re-run `shearzone profile` with the drive frequency (--f-hz)",
                                   path.string(), p.meta("lockin").empty() ? "absent" : p.meta("lockin")));
    const profile::WidthInput in = profile::width_input(p);
    Row row;
    row.label = path.stem().string();
    row.res = profile::shear_zone_width(in, wo);
    row.N = p.meta("N");
    row.phi0 = p.meta("phi0_rad");
    for (const auto& [k, v] : o.tags) {
      if (k == "N") row.N = v;
      else if (k == "phi0_rad") row.phi0 = v;
    }
    row.n_pairs = p.meta("n_pairs");
    WidthRow wr;
    wr.label = row.label;
    wr.status = row.res.status;
    wr.rc_m = row.res.rc_m;
    wr.estimator = row.res.estimator;
    if (row.res.status == profile::WidthStatus::kNoiseLimited && row.res.estimator == profile::Estimator::kLockin) {
      wr.rc_m = row.res.rc_m = row.res.ci_low_m = row.res.ci_high_m = core::kUnset;
      wr.advice = fmt::format(
          "{}: v_c = {} m/s is below {} x the lock-in floor {} m/s at the crossing: even the phase-locked amplitude "
          "cannot resolve v_c; average more pairs or cycles (the floor falls like 1/sqrt(n))",
          path.string(), format_number(wo.v_c_m_per_s), format_number(wo.noise_factor),
          format_number(row.res.v_noise_m_per_s));
    } else if (row.res.status == profile::WidthStatus::kNoiseLimited) {
      // An r_c that cannot be trusted is not reported.
      wr.rc_m = row.res.rc_m = row.res.ci_low_m = row.res.ci_high_m = core::kUnset;
      // v_c k / fps must exceed 5 x the PIV noise (px) in metres: sigma_px m_per_px.
      const double sigma = p.meta_number("noise_sigma_m_per_s");
      const double dt = p.meta_number("dt_s"), fps = p.meta_number("fps");
      std::string k_text = "a larger pair spacing";
      if (!std::isnan(sigma) && !std::isnan(dt) && !std::isnan(fps) && sigma > 0) {
        const double k0 = std::max(1.0, std::round(dt * fps));
        const double k = std::ceil(5.0 * sigma * dt * fps / wo.v_c_m_per_s);
        k_text = fmt::format("pair spacing k >= {} (now {})", format_number(std::max(k, k0 + 1)),
                             format_number(k0));
      }
      wr.advice = fmt::format(
          "{}: v_c = {} m/s is below {} x the noise floor {} m/s: r_c cannot be trusted; re-run "
          "`shearzone piv` with {} so that v_c k/fps exceeds 5x the PIV RMS{}",
          path.string(), format_number(wo.v_c_m_per_s), format_number(wo.noise_factor),
          format_number(row.res.v_noise_m_per_s), k_text,
          p.has_lockin ? "" : ", or give `shearzone profile` the drive frequency (--f-hz) so that the lock-in "
                              "estimator can run");
    }
    wr.ci_low_m = row.res.ci_low_m;
    wr.ci_high_m = row.res.ci_high_m;
    wr.v_noise_m_per_s = row.res.v_noise_m_per_s;
    report.push_back(wr);
    rows.push_back(std::move(row));
  }
  core::Metadata meta = header;
  meta.emplace_back("v_c_m_per_s", format_number(wo.v_c_m_per_s));
  meta.emplace_back("noise_factor", format_number(wo.noise_factor));
  meta.emplace_back("bootstrap", std::to_string(wo.bootstrap));
  meta.emplace_back("confidence", format_number(wo.confidence));
  meta.emplace_back("seed", std::to_string(wo.seed));
  meta.emplace_back("estimator_option", profile::estimator_name(wo.estimator));
  meta.emplace_back("estimator", "per row: mean_abs (the paper's mean |v| per bin) or lockin (the mean |v_theta| "
                                 "implied by the phase-locked waveform of v_theta; auto takes it where mean_abs is "
                                 "noise_limited)");
  meta.emplace_back("rc_m", "first radius (outwards from the vane) where the estimator's velocity < v_c, ln v "
                            "interpolated between the two bracketing bins at the mean radii of their vectors "
                            "(r_vectors_mean_m), each bin's ln v less s^2 / (2 lambda^2) for its vectors' spread s "
                            "(exact to second order for an exponential decay; a profile without those columns: between "
                            "the bin centres less lambda ln(sinh(x)/x), x = bin / (2 lambda), radii taken as evenly "
                            "spread); linear where a bin is <= 0; never_below: R (a lower bound); "
                            "below_at_vane: the first bin centre (an upper bound); noise_limited: empty");
  meta.emplace_back("rc_ci", "percentile bootstrap of the profile's per-pair bin means under rc_ci_method, each side "
                             "h combined with the binning's bound b as a rectangular error, sqrt(h^2 + z^2 b^2 / 3) (b = "
                             "max(s^4) / (20 lambda^3), the next order; without the vectors' radii b = lambda "
                             "ln(sinh(x)/x), the correction itself); the low side also holds rc_resolution_bound_m in quadrature and each side the shift of "
                             "rc_velocity_bias_bound_m that way as a rectangular error; empty "
                             "when there is no replicate (one pair)");
  meta.emplace_back("rc_resolution_bound_m",
                    "how far r_c may read high because each velocity is a mean over a footprint (the profile's "
                    "velocity_footprint_var_m2: the PIV's final window and the texture it follows), var / (2 "
                    "lambda) for a decay of length lambda; the interval's low end holds it; 0: no footprint known; "
                    "empty unless rc_status is ok");
  meta.emplace_back("rc_velocity_bias_bound_m",
                    "how far the velocities' bias bound (the profile's velocity_bias_bound_m_per_s: piv reads a "
                    "displacement within 0.01 px) moves r_c, lambda ln(1 + e) outwards, -lambda ln(1 - e) inwards, "
                    "e = bound / v_c; the larger of the two; the interval holds each side as a rectangular error; 0: "
                    "none known; empty unless rc_status is ok");
  meta.emplace_back("rc_ci_method",
                    "cycles: whole oscillation cycles resampled (>= 8 cycles; rc_ci_units of them); "
                    "pairs_phase_detrended: phase modulation fitted (Fourier series in the phase), "
                    "residuals an AR(1) series of lag-1 correlation rc_ci_rho (AR-sieve bootstrap); "
                    "pairs: the same about the mean (frequency unknown); wild_cycles / wild_pair_blocks (lockin): "
                    "wild bootstrap of the lock-in fit, signs flipped per cycle or per block of pairs "
                    "(rc_ci_units clusters), widened by t_(G-1)/z; none: no interval");
  meta.emplace_back("v_noise_m_per_s", "the floor the status used: mean_abs: median over bins of v_noise; lockin: "
                                       "the lock-in floor at the crossing");
  io::AtomicOutput out(o.output, o.force);
  {
    io::CsvWriter w(out.stream(), meta,
                    {"label", "N", "phi0_rad", "rc_m", "rc_ci_low_m", "rc_ci_high_m", "rc_status", "estimator",
                     "rc_ci_method", "rc_ci_units", "rc_ci_rho", "v_noise_m_per_s", "n_pairs",
                     "rc_resolution_bound_m", "rc_velocity_bias_bound_m"});
    for (const auto& r : rows) {
      const bool ci = std::isfinite(r.res.ci_low_m);
      const bool lk = r.res.estimator == profile::Estimator::kLockin;
      const bool ok = r.res.status == profile::WidthStatus::kOk;
      const std::string method = !ci ? "none"
                                  : lk ? (r.res.grouping == profile::Grouping::kCycles ? "wild_cycles" : "wild_pair_blocks")
                                       : profile::grouping_name(r.res.grouping);
      w.row(std::vector<std::string>{
          r.label, r.N, r.phi0, io::format_number_or_empty(r.res.rc_m),
          io::format_number_or_empty(r.res.ci_low_m), io::format_number_or_empty(r.res.ci_high_m),
          profile::width_status_name(r.res.status), profile::estimator_name(r.res.estimator), method,
          ci ? std::to_string(r.res.bootstrap_units) : "",
          ci && r.res.grouping != profile::Grouping::kCycles ? fmt::format("{:.3f}", r.res.rho) : "",
          format_number(r.res.v_noise_m_per_s), r.n_pairs,
          ok ? format_number(r.res.resolution_bound_m) : "",
          ok ? format_number(std::max(r.res.velocity_bias.out_m, r.res.velocity_bias.in_m)) : ""});
    }
  }
  out.commit();
  return report;
}


}  // namespace shearzone::pipeline
