// `shearzone profile`: PIV fields -> radial profile v(r) (CSV) and its per-group
// companion. Flags map onto pipeline::ProfileJobOptions; --config FILE.toml sets them.
#include <cmath>
#include <cstdio>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include <memory>

#include "shearzone/pipeline/profile_job.hpp"
#include "subcommands.hpp"

namespace shearzone::apps {
namespace {

struct ProfileCli {
  pipeline::ProfileJobOptions job;
  std::string input, output, config, noise_ref;
  std::vector<double> centre, radii, detect_range, phase_range, noise_region;
};

int run_profile(CLI::App& c, ProfileCli& s, const Context& ctx) {
  configure(c, s.config, {"output"});
  auto& j = s.job;
  j.input = s.input;
  j.output = s.output;
  j.noise_ref = s.noise_ref;
  if (!s.centre.empty()) {
    if (!std::isfinite(s.centre[0]) || !std::isfinite(s.centre[1]))
      throw ConfigError(fmt::format("--centre {},{}: expected two finite pixel coordinates", s.centre[0],
                                    s.centre[1]));
    j.centre_x_px = s.centre[0];
    j.centre_y_px = s.centre[1];
  }
  if (!s.radii.empty()) {
    j.vane_radius_px = s.radii[0];
    j.cup_radius_px = s.radii[1];
  }
  if (!s.detect_range.empty()) {
    j.detect_min_radius_px = s.detect_range[0];
    j.detect_max_radius_px = s.detect_range[1];
  }
  if (!s.phase_range.empty()) {
    j.phase_min_deg = s.phase_range[0];
    j.phase_max_deg = s.phase_range[1];
  }
  if (!s.noise_region.empty()) {
    j.noise_min_m = s.noise_region[0];
    j.noise_max_m = s.noise_region[1];
  }
  if (ctx.check_options) {  // the study's option check: no file read
    j.validate();
    return kExitOk;
  }
  core::ProgressReporter progress("profile: pairs", ctx.level);
  const auto sum = pipeline::run_profile_job(j, ctx.header(), progress.callback());
  progress.finish();
  if (ctx.level != core::LogLevel::kQuiet) {
    std::printf("profile: %zu of %zu pairs in %zu group%s, %zu bins of %.4g m from %.4g to %.4g m "
                "-> %s\n",
                sum.pairs_used, sum.pairs_read, sum.groups, sum.groups == 1 ? "" : "s", sum.bins,
                sum.bin_m, sum.Rv_m, sum.R_m, j.output.string().c_str());
    std::printf("profile: centre (%.2f, %.2f) px [%s], %.4g m/px [%s], noise floor %.3g m/s, "
                "errors from %s\n",
                sum.centre_x_px, sum.centre_y_px, sum.geometry_source.c_str(), sum.m_per_px,
                sum.scale_source.c_str(), sum.noise_floor_m_per_s, sum.grouping.c_str());
    if (!sum.drive_phase_source.empty())
      std::printf("profile: drive phase t0 = %.6g s [%s]; lock-in %s\n", sum.t0_s, sum.drive_phase_source.c_str(),
                  sum.lockin ? "columns written" : "not run");
  }
  return kExitOk;
}

}  // namespace

std::vector<Subcommand> add_profile(CLI::App& root, Context& ctx) {
  auto s = std::make_shared<ProfileCli>();
  auto& j = s->job;
  CLI::App* c = root.add_subcommand(
      "profile", "Radial velocity profile v(r) of PIV fields (HDF5 clip or CSV pair) -> CSV");
  c->add_option("input", s->input, "Fields: .h5 from `shearzone piv`, a single-pair .csv, or the tracks .h5 of `piv --method track --tracks` (a vector per bead)")
      ->required();
  c->add_option("-o,--output", s->output, "Profile CSV (a <stem>_groups.csv is written beside it)");
  c->add_option("--config", s->config, "TOML file setting any of these options by long name");
  c->add_flag("--force", j.force, "Replace existing outputs");
  // Geometry and calibration
  c->add_option("--centre", s->centre,
                "Cup centre X,Y in px (default: the file's attributes); range: any finite numbers")
      ->expected(2)
      ->delimiter(',');
  c->add_option("--radii-px", s->radii, "Vane radius R_v and cup radius R, px; range: 0 <= R_v < R, finite")
      ->expected(2)
      ->delimiter(',');
  c->add_option("--detect-cup", j.detect_cup_frame,
                "Find centre and R from the cup rim in this image or video (first frame)");
  c->add_option("--detect-radius-px", s->detect_range,
                "Rim radius search range MIN,MAX, px; range: 0 < MIN < MAX <= 32768")
      ->expected(2)
      ->delimiter(',');
  c->add_option("--m-per-px", j.m_per_px,
                "Scale, m per px (default: the file's m_per_px); range: > 0, finite");
  c->add_option("--cup-radius-m", j.cup_radius_m,
                "Cup inner radius R in m: scale = R_m / R_px; range: > 0, finite");
  c->add_option("--scale-from", j.scale_from,
                "Which scale to use when sources disagree by > 1 %: m-per-px, cup-radius, file");
  // Bins
  c->add_option("--bin-m", j.bin_m, "Bin width, m; range: > 0 (at most 1e5 bins)");
  c->add_option("--bin-px", j.bin_px, "Bin width, px; range: > 0 (at most 1e5 bins)");
  c->add_option("--bead-diameter-m", j.bead_diameter_m, "Bead diameter; default bin = d/2, m; range: > 0")
      ->capture_default_str();
  c->add_flag("--exclude-replaced", j.exclude_replaced, "Drop `replaced` vectors too");
  // Selection
  c->add_option("--f-hz", j.f_Hz,
                "Oscillation frequency, Hz (default: the file's f_Hz); range: 0 < f <= 1e6");
  c->add_option("--t0-s", j.t0_s,
                "Time of an upward zero crossing of phi(t), s (default: from --log, the file's vane_phase_rad, "
                "else 0); range: any finite number");
  c->add_option("--log", j.log_path,
                "Vane angle log CSV (time_s, angle_rad): the drive's frequency and phase for the lock-in");
  c->add_option("--log-offset-s", j.log_offset_s,
                "Log time = field time + this, s (default: the file's vane_log_offset_s, else 0); range: finite");
  c->add_option("--lockin-harmonics", j.lockin_harmonics,
                "Lock-in estimator: highest odd harmonic of v_theta fitted (0: off); range: 0 or odd 1..31")
      ->capture_default_str();
  c->add_option("--cycles", j.cycles,
                "Cycles to average, e.g. 5,7,9 (default: all); "
                "range: any integers (cycle = floor(f (t - t0)))")
      ->delimiter(',');
  c->add_option("--phase-range-deg", s->phase_range,
                "Phase window MIN,MAX in deg; range: 0 <= MIN < MAX <= 360")
      ->expected(2)
      ->delimiter(',');
  c->add_option("--phase-bins", j.phase_bins,
                "Phase-resolved: K profiles <stem>_phaseKK.csv over equal phase bins; range: 0..360")
      ->capture_default_str();
  c->add_option("--groups", j.groups,
                "What standard errors and the r_c bootstrap resample: auto (cycles when >= 8, "
                "else pairs), cycles, pairs")
      ->capture_default_str();
  c->add_option("--dt-s", j.dt_s, "Time step of a CSV pair, s; range: > 0, finite");
  // Noise
  c->add_option("--noise-ref", s->noise_ref, "Static reference fields (.h5 or .csv) for the noise floor");
  c->add_option("--noise-region-m", s->noise_region,
                "Radii MIN,MAX (m) of a region that does not move (default: outer 15 %); "
                "range: MIN < MAX")
      ->expected(2)
      ->delimiter(',');
  return {{c, [c, s, &ctx] { return run_profile(*c, *s, ctx); }}};
}

}  // namespace shearzone::apps
