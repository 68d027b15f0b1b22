#include "shearzone/pipeline/profile_job.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/core/sine_fit.hpp"
#include "shearzone/core/stats.hpp"
#include "shearzone/core/unset.hpp"
#include "shearzone/core/point_vectors.hpp"
#include "shearzone/io/angle_log.hpp"
#include "shearzone/io/atomic_output.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/io/field_file.hpp"
#include "shearzone/io/frames.hpp"
#include "shearzone/io/profile_csv.hpp"
#include "shearzone/io/track_file.hpp"
#include "shearzone/profile/geometry.hpp"
#include "shearzone/profile/radial_profile.hpp"
#include "shearzone/profile/width.hpp"


namespace shearzone::pipeline {

namespace {

static_assert(profile::PairSeries::kNoCycle == io::ProfileGroupRow::kNoCycle);

using io::format_number;
bool set(double v) { return !std::isnan(v); }

/// The pairs of a field file (io/field_file.hpp) or a tracks file (io/track_file.hpp);
/// a CSV pair needs its time step.
std::unique_ptr<io::PairReader> open_pairs(const std::filesystem::path& path, double dt_s) {
  if (io::is_field_csv(path) && !set(dt_s))
    throw ConfigError(fmt::format("{}: a CSV field holds one pair without its time step: give "
                                  "--dt-s (pair spacing / fps)",
                                  path.string()));
  return io::open_pair_file(path, dt_s);
}

/// The drive's sinusoid in an angle log: phi(t) = c + amplitude sin(2 pi f (t - t0)).
struct DriveFit {
  double f_Hz = 0, t0_s = 0, amplitude_rad = 0, r2 = 0;
};

/// The drive sinusoid of an angle log (columns time_s, angle_rad): the sine fit of
/// core/sine_fit.hpp, its frequency found in the log alone (the fields' f is then
/// checked against it, not assumed).
DriveFit fit_drive_log(const std::string& path) {
  const io::AngleLog log = io::read_angle_log(path, 8);
  const core::SineFit s = core::fit_sine(log.time_s, log.angle_rad, core::kUnset, path);
  const std::vector<double>& y = log.angle_rad;
  const double n = static_cast<double>(y.size());
  double mean = 0, tss = 0;
  for (const double v : y) mean += v;
  mean /= n;
  for (const double v : y) tss += (v - mean) * (v - mean);
  DriveFit d;
  d.f_Hz = s.omega / (2.0 * std::numbers::pi);
  d.amplitude_rad = s.x0;
  // x0 sin(omega t + psi): an upward zero crossing at omega t = -psi.
  const double T = 1.0 / d.f_Hz;
  d.t0_s = std::fmod(-s.psi / s.omega, T);
  if (d.t0_s < 0) d.t0_s += T;
  d.r2 = tss > 0 ? 1.0 - s.rms * s.rms * n / tss : 0.0;
  if (!(d.r2 >= 0.9))
    throw InputError(fmt::format("{}: a sinusoid explains {:.3f} of the angle log's variance; expected at least 0.9 "
                                 "(the lock-in needs a sinusoidal drive)",
                                 path, d.r2));
  return d;
}

cv::Mat first_frame(const std::string& path) {
  auto src = io::open_frames({path}, 25.0);
  io::Frame fr;
  if (!src->next(fr)) throw InputError(fmt::format("{}: no frame to detect the cup in", path));
  return fr.gray;
}

/// What width needs to bound the PIV's systematic errors, from piv's attributes (none
/// for fields piv did not write): the footprint each velocity is a mean over
/// (profile::piv_footprint_var_m2) and piv's displacement bias bound over the pair's
/// time step (profile::piv_velocity_bias_bound).
void add_velocity_bounds(core::Metadata& meta, const io::PairReader& src, double m_per_px, double dt_s) {
  const double cell = src.attribute("track_cell_px");
  const double W = src.attribute("piv_final_window_px");
  const bool tracked = src.beads() || (set(cell) && cell > 0 && cell < 1e5);
  if (src.beads()) {
    // Each vector one bead, at the midpoint of its displacement: nothing is averaged.
    meta.emplace_back("velocity_footprint_var_m2", "0");
    meta.emplace_back("velocity_footprint", "0: tracked beads from a tracks file, each vector one bead at the "
                                            "midpoint of its displacement");
  } else if (tracked) {
    // Tracked beads: each vector the mean of the bead centres in its cell (no texture term).
    meta.emplace_back("velocity_footprint_var_m2", format_number(profile::piv_footprint_var_m2(cell, 0.0, m_per_px)));
    meta.emplace_back("velocity_footprint",
                      fmt::format("c^2 / 12 m_per_px^2: tracked beads, each vector the mean of the beads whose centre "
                                  "lies in a cell of c = {} px; width bounds how far r_c reads high by it",
                                  format_number(cell)));
  } else if (set(W) && W > 0 && W < 1e5) {
    const double d = src.attribute("texture_size_px");
    const double d_px = set(d) && d > 0 && d < 1e5 ? d : 0.0;
    meta.emplace_back("velocity_footprint_var_m2", format_number(profile::piv_footprint_var_m2(W, d_px, m_per_px)));
    meta.emplace_back("velocity_footprint",
                      fmt::format("(W^2 / 12 + d^2 / 4) m_per_px^2: piv's final window W = {} px, texture d = {} px "
                                  "({}); width bounds how far r_c reads high by it",
                                  format_number(W), format_number(d_px),
                                  d_px > 0 ? "texture_size_px of the field file" : "unknown: 0"));
  } else {
    return;
  }
  meta.emplace_back("velocity_bias_bound_m_per_s", format_number(profile::piv_velocity_bias_bound(m_per_px, dt_s)));
  meta.emplace_back("velocity_bias_bound",
                    fmt::format("{}'s displacement bias, at most {} px per pair (docs/{}.md), over dt = {} s; "
                                "width bounds how far it moves r_c",
                                tracked ? "the tracker" : "piv",
                                format_number(profile::kPivBiasBoundPx), tracked ? "track" : "piv", format_number(dt_s)));
}

}  // namespace

void ProfileJobOptions::validate() const {
  if (set(dt_s) && !(dt_s > 0)) throw ConfigError(fmt::format("--dt-s {}: must be positive", dt_s));
  if (!(phase_min_deg >= 0 && phase_max_deg <= 360 && phase_min_deg < phase_max_deg))
    throw ConfigError(fmt::format("--phase-range-deg {} {}: expected 0 <= min < max <= 360",
                                  phase_min_deg, phase_max_deg));
  if (set(noise_min_m) != set(noise_max_m) || (set(noise_min_m) && !(noise_min_m < noise_max_m)))
    throw ConfigError("--noise-region-m: expected two radii, min < max, in m");
  if (!(bead_diameter_m > 0)) throw ConfigError("--bead-diameter-m: must be positive");
  if (set(m_per_px) && !(std::isfinite(m_per_px) && m_per_px > 0))
    throw ConfigError(fmt::format("--m-per-px {}: expected a positive number", m_per_px));
  if (set(cup_radius_m) && !(std::isfinite(cup_radius_m) && cup_radius_m > 0))
    throw ConfigError(fmt::format("--cup-radius-m {}: expected a positive number", cup_radius_m));
  if (!scale_from.empty() && scale_from != "m-per-px" && scale_from != "cup-radius" && scale_from != "file")
    throw ConfigError(fmt::format("--scale-from {}: expected m-per-px, cup-radius or file", scale_from));
  if (groups != "auto" && groups != "cycles" && groups != "pairs")
    throw ConfigError(fmt::format("--groups {}: expected auto, cycles or pairs", groups));
  if (set(f_Hz) && !(f_Hz > 0 && f_Hz <= 1e6))
    throw ConfigError(fmt::format("--f-hz {}: expected 0 < f <= 1e6 Hz", f_Hz));
  if (set(t0_s) && !std::isfinite(t0_s)) throw ConfigError(fmt::format("--t0-s {}: expected a finite time, s", t0_s));
  if (set(log_offset_s) && !std::isfinite(log_offset_s))
    throw ConfigError(fmt::format("--log-offset-s {}: expected a finite time, s", log_offset_s));
  if (!(lockin_harmonics == 0 || (lockin_harmonics >= 1 && lockin_harmonics <= 31 && lockin_harmonics % 2 == 1)))
    throw ConfigError(fmt::format("--lockin-harmonics {}: expected 0 (off) or an odd number 1..31", lockin_harmonics));
  if (set(detect_min_radius_px) &&
      !(detect_min_radius_px > 0 && detect_max_radius_px > detect_min_radius_px && detect_max_radius_px <= 32768))
    throw ConfigError(fmt::format("--detect-radius-px {},{}: expected 0 < min < max <= 32768 px",
                                  detect_min_radius_px, detect_max_radius_px));
  if (phase_bins < 0 || phase_bins > 360)
    throw ConfigError(fmt::format("--phase-bins {}: expected 0..360", phase_bins));
}

namespace {

/// The cup in the image: centre, wall and vane radii (px; unset where no source has them).
struct CupInImage {
  double cx = core::kUnset, cy = core::kUnset, R_px = core::kUnset, Rv_px = core::kUnset;
};

/// Geometry: given > the rim detected in a frame > the field file's attributes.
CupInImage find_geometry(const ProfileJobOptions& o, const io::PairReader& src, ProfileJobSummary& sum) {
  CupInImage g{o.centre_x_px, o.centre_y_px, o.cup_radius_px, o.vane_radius_px};
  sum.geometry_source = "given";
  if (!o.detect_cup_frame.empty() && (!set(g.cx) || !set(g.R_px))) {
    const double lo = set(o.detect_min_radius_px) ? o.detect_min_radius_px : 50.0;
    const double hi = set(o.detect_max_radius_px) ? o.detect_max_radius_px : 5000.0;
    const auto c = profile::detect_cup_circle(first_frame(o.detect_cup_frame), lo, hi);
    if (!set(g.cx)) {
      g.cx = c.centre_x_px;
      g.cy = c.centre_y_px;
    }
    if (!set(g.R_px)) g.R_px = c.radius_px;
    sum.geometry_source = fmt::format("rim detected in {} (rms {} px, {} edge px)", o.detect_cup_frame,
                                      format_number(c.rms_residual_px), c.edge_points);
  }
  if (!set(g.cx)) {
    g.cx = src.attribute("centre_x_px");
    g.cy = src.attribute("centre_y_px");
    sum.geometry_source = "field attributes";
  }
  if (!set(g.R_px)) g.R_px = src.attribute("cup_radius_px");
  if (!set(g.Rv_px)) g.Rv_px = src.attribute("vane_radius_px");
  if (!set(g.Rv_px)) g.Rv_px = 0.0;
  if (!set(g.cx) || !set(g.cy))
    throw ConfigError(fmt::format("{}: no cup centre: give --centre X Y or --detect-cup FRAME (the "
                                  "file has no centre_x_px/centre_y_px attributes)",
                                  o.input.string()));
  return g;
}

/// The scale: every source there is, then one of them (see ProfileJobOptions); a cup
/// radius still unknown in px then comes from --cup-radius-m.
double find_scale(const ProfileJobOptions& o, const io::PairReader& src, CupInImage& g, ProfileJobSummary& sum) {
  struct ScaleSource {
    const char* name;
    double m_per_px;
    std::string text;
  };
  std::vector<ScaleSource> scales;
  if (set(o.m_per_px))
    scales.push_back({"m-per-px", o.m_per_px, fmt::format("--m-per-px {}", format_number(o.m_per_px))});
  if (set(o.cup_radius_m) && set(g.R_px)) {
    const double m = profile::m_per_px_from_radius(o.cup_radius_m, g.R_px);
    scales.push_back({"cup-radius", m,
                      fmt::format("--cup-radius-m {} / R = {} px = {} m/px", format_number(o.cup_radius_m),
                                  format_number(g.R_px), fmt::format("{:.6g}", m))});
  }
  const double file_scale = src.attribute("m_per_px");
  if (set(file_scale))
    scales.push_back({"file", file_scale,
                      fmt::format("m_per_px = {} in {}", format_number(file_scale), o.input.string())});
  double m_per_px = core::kUnset;
  if (!o.scale_from.empty()) {
    for (const auto& sc : scales)
      if (o.scale_from == sc.name) {
        m_per_px = sc.m_per_px;
        sum.scale_source = sc.text + " (--scale-from)";
      }
    if (!set(m_per_px))
      throw ConfigError(fmt::format("--scale-from {}: that source of the scale is not available{}",
                                    o.scale_from,
                                    o.scale_from == "cup-radius" ? " (give --cup-radius-m and R in px)"
                                    : o.scale_from == "file"     ? " (the field file has no m_per_px)"
                                                                 : " (give --m-per-px)"));
  } else if (!scales.empty()) {
    for (std::size_t a = 0; a < scales.size(); ++a)
      for (std::size_t b = a + 1; b < scales.size(); ++b) {
        const double rel = std::abs(scales[a].m_per_px - scales[b].m_per_px) /
                           std::min(scales[a].m_per_px, scales[b].m_per_px);
        if (rel > kScaleTolerance)
          throw ConfigError(fmt::format(
              "{}: two scales disagree by {:.3g} %: {} and {}; say which to use with --scale-from {} "
              "or --scale-from {}",
              o.input.string(), 100 * rel, scales[a].text, scales[b].text, scales[a].name, scales[b].name));
      }
    m_per_px = scales.front().m_per_px;
    sum.scale_source = scales.front().text;
    if (scales.size() > 1) sum.scale_source += fmt::format(" (agrees with {} within 1 %)", scales[1].text);
  }
  if (!set(m_per_px)) {
    if (!set(o.cup_radius_m))
      throw ConfigError(fmt::format("{}: no scale: give --m-per-px or --cup-radius-m (with the cup "
                                    "radius in px)",
                                    o.input.string()));
    throw ConfigError("--cup-radius-m needs the cup radius in px: give --radii-px RV,R or "
                      "--detect-cup FRAME");
  }
  if (!(std::isfinite(m_per_px) && m_per_px > 0))
    throw InputError(fmt::format("{}: scale {} m/px: expected a positive number", o.input.string(),
                                 format_number(m_per_px)));
  if (!set(g.R_px)) {
    if (!set(o.cup_radius_m))
      throw ConfigError("no cup radius: give --radii-px RV,R, --detect-cup FRAME or --cup-radius-m");
    g.R_px = o.cup_radius_m / m_per_px;
  }
  return m_per_px;
}

/// A phase window or phase bins: the lock-in, which fits a whole cycle, does not run.
bool phase_window(const ProfileJobOptions& o) {
  return o.phase_min_deg > 0 || o.phase_max_deg < 360 || o.phase_bins > 0;
}

profile::ProfileOptions profile_options(const ProfileJobOptions& o, const CupInImage& g, double m_per_px) {
  profile::ProfileOptions po;
  po.centre_x_px = g.cx;
  po.centre_y_px = g.cy;
  po.m_per_px = m_per_px;
  po.r_min_m = g.Rv_px * m_per_px;
  po.r_max_m = g.R_px * m_per_px;
  po.bin_m = set(o.bin_m) ? o.bin_m : (set(o.bin_px) ? o.bin_px * m_per_px : 0.5 * o.bead_diameter_m);
  po.exclude_replaced = o.exclude_replaced;
  po.grouping = o.groups == "cycles"  ? profile::Grouping::kCycles
                : o.groups == "pairs" ? profile::Grouping::kPairsPhaseDetrended
                                      : profile::Grouping::kNone;
  po.lockin_harmonics = phase_window(o) ? 0 : o.lockin_harmonics;
  po.validate();
  return po;
}

/// The drive: its frequency f (unset: unknown) and t0, an upward zero crossing of the
/// vane angle: the angle log > --t0-s > the file's vane_phase_rad > assumed 0.
struct Drive {
  double f = core::kUnset, t0 = 0.0;
};
Drive find_drive(const ProfileJobOptions& o, const io::PairReader& src, ProfileJobSummary& sum) {
  Drive dr;
  dr.f = set(o.f_Hz) ? o.f_Hz : src.attribute("f_Hz");
  const double f = dr.f;
  if (set(f) && !(f > 0 && f <= 1e6))
    throw InputError(fmt::format("{}: attribute f_Hz = {}: expected 0 < f <= 1e6 Hz", o.input.string(), f));
  if (!o.log_path.empty()) {
    const DriveFit d = fit_drive_log(o.log_path);
    if (set(f) && std::abs(d.f_Hz - f) > kScaleTolerance * f)
      throw ConfigError(fmt::format("{}: the angle log oscillates at {:.6g} Hz, the fields say f = {} Hz: the inputs "
                                    "disagree by more than 1 %",
                                    o.log_path, d.f_Hz, format_number(f)));
    const double file_off = src.attribute("vane_log_offset_s");
    const double off = set(o.log_offset_s) ? o.log_offset_s : (set(file_off) ? file_off : 0.0);
    dr.f = d.f_Hz;
    dr.t0 = d.t0_s - off;
    sum.drive_phase_source = fmt::format(
        "angle log {} (sinusoid fitted: f = {:.8g} Hz, amplitude {:.4g} rad, R^2 = {:.5f}; log time = field time + {} s{})",
        o.log_path, d.f_Hz, d.amplitude_rad, d.r2, format_number(off),
        set(o.log_offset_s) ? " (--log-offset-s)" : set(file_off) ? " (the file's vane_log_offset_s)" : " (assumed)");
  } else if (set(o.t0_s)) {
    dr.t0 = o.t0_s;
    sum.drive_phase_source = "--t0-s";
  } else if (set(f) && set(src.attribute("vane_phase_rad"))) {
    const double ph = src.attribute("vane_phase_rad");
    dr.t0 = -ph / (2.0 * std::numbers::pi * f);
    sum.drive_phase_source = fmt::format("the file's vane_phase_rad = {} (phi = phi0 sin(2 pi f t + phase))",
                                         format_number(ph));
  } else if (set(f)) {
    sum.drive_phase_source = "assumed: phi = phi0 sin(2 pi f t) (no --log, --t0-s or vane_phase_rad attribute)";
  }
  sum.t0_s = dr.t0;
  const bool selecting = !o.cycles.empty() || phase_window(o);
  if (selecting && !(dr.f > 0))
    throw ConfigError("--cycles / --phase-range-deg / --phase-bins need the oscillation frequency: "
                      "give --f-hz (the field file has no f_Hz attribute)");
  return dr;
}

/// The selected pairs, one accumulator per phase bin, their median time step and the
/// lock-in's harmonics as the pairs allow them.
struct Accumulated {
  std::vector<profile::ProfileAccumulator> accs;
  double phase_width_deg = 360.0;
  double dt_median = 0.0;
  int lockin_harmonics = 0;
};
Accumulated accumulate_pairs(const ProfileJobOptions& o, io::PairReader& src, const profile::ProfileOptions& po,
                             const Drive& dr, ProfileJobSummary& sum, const core::ProgressCallback& progress) {
  const double f = dr.f;
  const int nphase = std::max(1, o.phase_bins);
  Accumulated a;
  a.phase_width_deg = (o.phase_max_deg - o.phase_min_deg) / nphase;
  a.accs.assign(static_cast<std::size_t>(nphase), profile::ProfileAccumulator(po));
  core::PointVectors points;
  std::vector<double> dts;
  const std::size_t n = src.size();
  for (std::size_t k = 0; k < n; ++k) {
    double t_a = 0, dt = 0;
    src.read_points(k, points, t_a, dt);
    ++sum.pairs_read;
    int cycle = profile::PairSeries::kNoCycle;
    double phase = core::kUnset;
    std::size_t ph = 0;
    if (f > 0) {
      const auto cp = profile::cycle_phase(t_a + 0.5 * dt, f, dr.t0);
      if (!o.cycles.empty() && std::find(o.cycles.begin(), o.cycles.end(), cp.cycle) == o.cycles.end())
        continue;
      if (cp.phase_deg < o.phase_min_deg || cp.phase_deg >= o.phase_max_deg) continue;
      cycle = cp.cycle;
      phase = cp.phase_deg / 360.0;
      ph = std::min(static_cast<std::size_t>(nphase - 1),
                    static_cast<std::size_t>((cp.phase_deg - o.phase_min_deg) / a.phase_width_deg));
    }
    if (!(dt > 0))
      throw InputError(fmt::format("{}: pair {}: dt_s = {}: expected a positive time step",
                                   o.input.string(), k, dt));
    a.accs[ph].add(points, dt, cycle, phase, f > 0 ? f * dt : 0.0);
    dts.push_back(dt);
    ++sum.pairs_used;
    if (progress) progress(k + 1, n);
  }
  if (sum.pairs_used == 0)
    throw NoResultError(fmt::format("{}: no pair selected ({} read): check --cycles, "
                                    "--phase-range-deg, --t0-s and f",
                                    o.input.string(), sum.pairs_read));
  a.dt_median = core::upper_median_inplace(dts);  // dts: all > 0, at least one
  a.lockin_harmonics = po.lockin_harmonics;
  int& h = a.lockin_harmonics;
  if (h > 0 && f > 0) {
    while (h >= 1 && (4 * (h + 2) > static_cast<int>(sum.pairs_used) || h * f * a.dt_median > 0.25)) h -= 2;
    h = std::max(h, 0);
    for (auto& acc : a.accs) acc.set_lockin_harmonics(h);
  }
  return a;
}

/// The noise floor: a static reference clip, the file's own noise_sigma_px, or the
/// scatter of v_r in a region of each profile.
struct NoiseFloor {
  std::unique_ptr<profile::ProfileAccumulator> reference;
  double known_m_per_s = std::numeric_limits<double>::quiet_NaN();
  double region_lo_m = 0.0, region_hi_m = 0.0;
  std::string method;
  [[nodiscard]] profile::RadialProfile finish(const profile::ProfileAccumulator& acc) const {
    return reference              ? acc.finish_with_reference_noise(*reference)
           : set(known_m_per_s) ? acc.finish_with_known_noise(known_m_per_s)
                                : acc.finish_with_region_noise(region_lo_m, region_hi_m);
  }
};
NoiseFloor noise_floor(const ProfileJobOptions& o, const io::PairReader& src, const profile::ProfileOptions& po,
                       double m_per_px, double dt_median) {
  NoiseFloor nf;
  nf.region_lo_m = set(o.noise_min_m) ? o.noise_min_m : po.r_max_m - 0.15 * (po.r_max_m - po.r_min_m);
  nf.region_hi_m = set(o.noise_max_m) ? o.noise_max_m : po.r_max_m;
  if (!o.noise_ref.empty()) {
    auto ref = open_pairs(o.noise_ref, o.dt_s);
    nf.reference = std::make_unique<profile::ProfileAccumulator>(po);
    core::PointVectors rp;
    for (std::size_t k = 0; k < ref->size(); ++k) {
      double t_a = 0, dt = 0;
      ref->read_points(k, rp, t_a, dt);
      // The reference is static: its displacements are noise in px per pair; convert
      // them with the time step of the measurement so that both floors compare.
      nf.reference->add(rp, dt_median);
    }
    nf.method = fmt::format("mean |v| per bin of the static reference {} ({} pairs)", o.noise_ref.string(),
                            ref->size());
  } else if (const double known_px = src.attribute("noise_sigma_px");
             set(known_px) && !set(o.noise_min_m) && !set(o.noise_max_m)) {
    // The field file states its own measurement noise (the simulator's exact surface: 0);
    // real radial motion of the beads is then motion, not noise.
    if (!(known_px >= 0.0))
      throw InputError(fmt::format("{}: attribute noise_sigma_px = {}: expected >= 0 px", o.input.string(),
                                   format_number(known_px)));
    nf.known_m_per_s = known_px * m_per_px / dt_median;
    nf.method = fmt::format("sigma*sqrt(pi/2), sigma = {} px per component, the field file's noise_sigma_px "
                            "attribute (exact fields: 0); --noise-region-m or --noise-ref override it",
                            format_number(known_px));
  } else {
    nf.method = fmt::format("sigma*sqrt(pi/2), sigma = scatter of v_r in {} <= r <= {} m",
                            format_number(nf.region_lo_m), format_number(nf.region_hi_m));
  }
  return nf;
}

/// The header every phase bin's profile shares.
core::Metadata profile_metadata(const ProfileJobOptions& o, const io::PairReader& src, const core::Metadata& header,
                                const ProfileJobSummary& sum, const profile::ProfileOptions& po, const Drive& dr,
                                double dt_median, const std::string& noise_method) {
  const double f = dr.f;
  core::Metadata meta = header;
  meta.emplace_back("input", o.input.string());
  meta.emplace_back("vectors", src.beads() ? "tracked beads: one vector per bead and pair, at the midpoint of its "
                                             "displacement; a bead not tracked counts as invalid"
                                           : "the field file's grid nodes");
  meta.emplace_back("geometry_source", sum.geometry_source);
  meta.emplace_back("centre_x_px", format_number(po.centre_x_px));
  meta.emplace_back("centre_y_px", format_number(po.centre_y_px));
  meta.emplace_back("m_per_px", format_number(po.m_per_px));
  meta.emplace_back("scale_source", sum.scale_source);
  meta.emplace_back("Rv_m", format_number(po.r_min_m));
  meta.emplace_back("R_m", format_number(po.r_max_m));
  meta.emplace_back("bin_m", format_number(po.bin_m));
  meta.emplace_back("r_m", "bin centre; bin k covers [Rv + k bin, Rv + (k+1) bin)");
  meta.emplace_back("replaced_vectors", o.exclude_replaced ? "excluded (counted as invalid)" : "used");
  meta.emplace_back("f_Hz", set(f) ? format_number(f) : "unknown");
  meta.emplace_back("t0_s", format_number(dr.t0));
  meta.emplace_back("drive_phase_source", set(f) ? sum.drive_phase_source : "unknown (no frequency)");
  std::string cyc;
  for (int c : o.cycles) cyc += (cyc.empty() ? "" : ",") + std::to_string(c);
  meta.emplace_back("cycles", cyc.empty() ? "all" : cyc);
  meta.emplace_back("dt_s", format_number(dt_median));
  const double fps = src.attribute("fps");
  if (set(fps)) meta.emplace_back("fps", format_number(fps));
  meta.emplace_back("noise_method", noise_method);
  add_velocity_bounds(meta, src, po.m_per_px, dt_median);
  for (const char* tag : {"N", "phi0_rad"}) {
    const std::string v = src.text_attribute(tag);
    if (!v.empty()) meta.emplace_back(tag, v);
  }
  meta.emplace_back("v_abs_sem_m_per_s",
                    "standard deviation of 1000 bootstrap replicates of the bin mean (seed 1) under "
                    "`groups`; empty with a single pair");
  meta.emplace_back("r_vectors_mean_m", "mean radius of the vectors averaged in the bin (a grid of vectors fills a "
                                        "bin unevenly; width interpolates at it)");
  meta.emplace_back("r_vectors_sd_m", "standard deviation of those radii about their mean");
  meta.emplace_back("empty_cells", "a bin without vectors (n_vectors = 0) has no velocity values");
  return meta;
}

/// What one phase bin's profile adds to the header: its pairs, groups, noise and lock-in.
void add_phase_metadata(core::Metadata& m, const ProfileJobOptions& o, const profile::RadialProfile& p,
                        const Drive& dr, int lockin_harmonics) {
  m.emplace_back("n_pairs", std::to_string(p.n_pairs));
  {
    std::size_t nv = 0;
    for (const auto& b : p.bins) nv += b.n_vectors;
    m.emplace_back("replaced_vectors_used",
                   fmt::format("{} of {} vectors averaged ({:.2f} %): interpolations from valid "
                               "neighbours, kept by piv only for isolated holes",
                               p.n_replaced_used, nv, nv ? 100.0 * static_cast<double>(p.n_replaced_used) / static_cast<double>(nv) : 0.0));
  }
  m.emplace_back("groups", profile::grouping_name(p.grouping));
  m.emplace_back("n_groups", std::to_string(p.n_groups));
  m.emplace_back("noise_lag1_rho", p.grouping == profile::Grouping::kCycles || p.grouping == profile::Grouping::kNone ? "" : fmt::format("{:.3f}", p.rho));
  m.emplace_back("noise_sigma_m_per_s", format_number(p.noise_sigma_m_per_s));
  m.emplace_back("dv_theta_m_per_s",
                 fmt::format("the velocity fluctuation about the local mean (granular temperature sqrt(T)): within "
                             "each pair, the RMS of the bin's v_theta about a straight line in r fitted to them, pooled "
                             "over pairs (n - 2 degrees of freedom each), with noise_sigma_m_per_s removed in "
                             "quadrature; empty where the measured value (dv_theta_measured_m_per_s) is not above "
                             "{:.3g} noise_sigma, and everywhere unless the noise comes from --noise-ref (a static "
                             "clip) or the file's noise_sigma_px (the region's v_r scatter holds the beads' own "
                             "fluctuation). For PIV, only what a window's mean keeps of the beads' own motion",
                             std::sqrt(profile::kFluctuationAboveNoise)));
  if (p.lockin) {
    m.emplace_back("lockin_harmonics", std::to_string(p.lockin_harmonics));
    m.emplace_back("lockin_harmonics_requested", std::to_string(o.lockin_harmonics));
    m.emplace_back(
        "lockin",
        fmt::format("per bin, weighted least squares of the pairs' mean v_theta on c0 + sum over odd h <= {} of "
                    "a_h cos(h theta) + b_h sin(h theta), theta = 2 pi f (t - t0) (vane angle phi0 sin theta), "
                    "regressors averaged over each pair's interval; standard errors clustered by {} ({} "
                    "clusters{}; residual lag-1 correlation {:.3f})",
                    p.lockin_harmonics, p.lockin_clusters, p.lockin_n_clusters,
                    p.lockin_block_pairs ? fmt::format(" of {} pairs", p.lockin_block_pairs) : "",
                    p.lockin_rho));
    m.emplace_back("v_theta_lag_deg", "phase lag of v_theta's fundamental behind the vane's angular velocity; a "
                                      "drive phase error adds to it and multiplies v_theta_inphase by its cosine");
    m.emplace_back("v_abs_lockin_m_per_s", "mean |v_theta| over a cycle of the fitted waveform ((2/pi) amplitude for "
                                           "a sinusoid); v_noise_lockin_m_per_s: its value for a zero waveform");
  } else {
    m.emplace_back("lockin", !set(dr.f) ? "not run: the oscillation frequency is unknown"
                             : phase_window(o) ? "not run: a phase window or phase bins were selected"
                             : o.lockin_harmonics == 0 ? "off (--lockin-harmonics 0)"
                             : lockin_harmonics == 0 ? "not run: too few pairs per cycle or in all for the fundamental "
                                                       "(needs 12 pairs and f dt <= 1/4)"
                                                     : "not run");
  }
}

/// profile.csv's rows: a bin each; the fluctuation less the noise where it stands
/// above it (profile/radial_profile.hpp, ProfileBin::dv_theta), when the noise was
/// measured apart from the beads' motion (`noise_measured`: a static reference or
/// the file's own noise; the region's v_r scatter holds the beads' own fluctuation).
std::vector<io::ProfileCsvRow> profile_rows(const profile::RadialProfile& p, bool noise_measured) {
  std::vector<io::ProfileCsvRow> rows;
  for (const auto& b : p.bins) {
    io::ProfileCsvRow r{b.r_m, b.v_abs, b.v_theta, b.v_r, b.v_abs_rms, b.v_abs_sem, b.v_noise, b.n_vectors,
                        b.n_masked, b.n_invalid};
    r.r_vectors_mean = b.r_vectors_mean_m;
    r.r_vectors_sd = b.r_vectors_sd_m;
    r.dv_theta_measured = b.dv_theta;
    const double noise2 = p.noise_sigma_m_per_s * p.noise_sigma_m_per_s;
    if (noise_measured && b.dv_theta * b.dv_theta > profile::kFluctuationAboveNoise * noise2)
      r.dv_theta = std::sqrt(b.dv_theta * b.dv_theta - noise2);
    if (b.lockin.ok) {
      r.amp = b.lockin.amplitude;
      r.amp_se = b.lockin.amplitude_se;
      r.lag_deg = b.lockin.lag_deg;
      r.in_phase = b.lockin.in_phase;
      r.v_abs_lockin = b.lockin.v_abs;
      r.v_abs_lockin_se = b.lockin.v_abs_se;
      r.v_noise_lockin = b.lockin.v_noise;
      r.n_eff = b.lockin.n_eff;
      // A value without a floor cannot be judged: both or neither.
      if (!std::isfinite(r.v_noise_lockin)) r.v_abs_lockin = core::kUnset;
    }
    rows.push_back(r);
  }
  return rows;
}

/// profile_groups.csv's rows: a pair and bin each (bins without vectors left out).
std::vector<io::ProfileGroupRow> group_rows(const profile::RadialProfile& p) {
  std::vector<io::ProfileGroupRow> rows;
  const auto& ps = p.pairs;
  for (std::size_t k = 0; k < ps.num_pairs(); ++k)
    for (std::size_t b = 0; b < ps.n_bins; ++b) {
      const double nv = ps.n_vectors[k * ps.n_bins + b];
      if (nv == 0) continue;
      io::ProfileGroupRow g;
      g.pair = k;
      g.cycle = ps.cycle[k];
      g.phase_deg = 360.0 * ps.phase[k];
      g.phase_span_deg = 360.0 * ps.phase_span[k];
      g.r_m = p.bins[b].r_m;
      g.v_abs = ps.v_abs[k * ps.n_bins + b];
      g.v_theta = ps.v_theta[k * ps.n_bins + b];
      g.n_vectors = nv;
      rows.push_back(g);
    }
  return rows;
}

}  // namespace

ProfileJobSummary run_profile_job(const ProfileJobOptions& o, const core::Metadata& header,
                                  const core::ProgressCallback& progress) {
  o.validate();
  auto src = open_pairs(o.input, o.dt_s);
  ProfileJobSummary sum;
  CupInImage geometry = find_geometry(o, *src, sum);
  const double m_per_px = find_scale(o, *src, geometry, sum);
  const profile::ProfileOptions po = profile_options(o, geometry, m_per_px);
  const Drive drive = find_drive(o, *src, sum);
  Accumulated acc = accumulate_pairs(o, *src, po, drive, sum, progress);
  const NoiseFloor noise = noise_floor(o, *src, po, m_per_px, acc.dt_median);
  sum.centre_x_px = geometry.cx;
  sum.centre_y_px = geometry.cy;
  sum.m_per_px = m_per_px;
  sum.R_m = po.r_max_m;
  sum.Rv_m = po.r_min_m;
  sum.bin_m = po.bin_m;
  sum.bins = po.num_bins();
  const core::Metadata meta = profile_metadata(o, *src, header, sum, po, drive, acc.dt_median, noise.method);

  // One profile (and its groups file) per phase bin; all appear together or none.
  std::vector<std::unique_ptr<io::AtomicOutput>> outs;
  const int nphase = static_cast<int>(acc.accs.size());
  for (int ph = 0; ph < nphase; ++ph) {
    std::filesystem::path path = o.output;
    if (nphase > 1)
      path = o.output.parent_path() /
             fmt::format("{}_phase{:02d}{}", o.output.stem().string(), ph, o.output.extension().string());
    const double plo = o.phase_min_deg + ph * acc.phase_width_deg, phi = plo + acc.phase_width_deg;
    const profile::ProfileAccumulator& a = acc.accs[static_cast<std::size_t>(ph)];
    if (a.num_pairs() == 0)
      throw NoResultError(fmt::format("{}: no pair in phase bin {} ({}-{} deg): use fewer --phase-bins",
                                      o.input.string(), ph, format_number(plo), format_number(phi)));
    const profile::RadialProfile p = noise.finish(a);
    sum.groups += p.n_groups;
    sum.lockin = sum.lockin || p.lockin;
    if (ph == 0) {
      sum.noise_floor_m_per_s = p.bins.empty() ? 0 : p.bins.front().v_noise;
      sum.grouping = profile::grouping_name(p.grouping);
      sum.rho = p.rho;
    }
    core::Metadata m = meta;
    m.emplace_back("phase_range_deg", format_number(plo) + "," + format_number(phi));
    add_phase_metadata(m, o, p, drive, acc.lockin_harmonics);
    outs.push_back(std::make_unique<io::AtomicOutput>(path, o.force));
    io::write_profile_csv(outs.back()->stream(), m, profile_rows(p, noise.reference || set(noise.known_m_per_s)));
    outs.push_back(std::make_unique<io::AtomicOutput>(io::profile_groups_path(path), o.force));
    core::Metadata gm = header;
    gm.emplace_back("profile", path.filename().string());
    io::write_profile_groups_csv(outs.back()->stream(), gm, group_rows(p));
  }
  for (auto& out : outs) out->commit();
  return sum;
}

}  // namespace shearzone::pipeline
