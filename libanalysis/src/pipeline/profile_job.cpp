#include "shearzone/pipeline/profile_job.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/core/stats.hpp"
#include "shearzone/core/unset.hpp"
#include "shearzone/core/vector_field.hpp"
#include "shearzone/io/atomic_output.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/io/field_file.hpp"
#include "shearzone/io/frames.hpp"
#include "shearzone/io/profile_csv.hpp"
#include "shearzone/profile/geometry.hpp"
#include "shearzone/profile/radial_profile.hpp"
#include "shearzone/profile/width.hpp"

namespace shearzone::pipeline {

namespace {

static_assert(profile::PairSeries::kNoCycle == io::ProfileGroupRow::kNoCycle);

using io::format_number;
bool set(double v) { return !std::isnan(v); }

/// The pairs of a field file (io/field_file.hpp); a CSV pair needs its time step.
std::unique_ptr<io::FieldReader> open_fields(const std::filesystem::path& path, double dt_s) {
  if (io::is_field_csv(path) && !set(dt_s))
    throw ConfigError(fmt::format("{}: a CSV field holds one pair without its time step: give "
                                  "--dt-s (pair spacing / fps)",
                                  path.string()));
  return io::open_field_file(path, dt_s);
}

cv::Mat first_frame(const std::string& path) {
  auto src = io::open_frames({path}, 25.0);
  io::Frame fr;
  if (!src->next(fr)) throw InputError(fmt::format("{}: no frame to detect the cup in", path));
  return fr.gray;
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
  if (!std::isfinite(t0_s)) throw ConfigError(fmt::format("--t0-s {}: expected a finite time, s", t0_s));
  if (set(detect_min_radius_px) &&
      !(detect_min_radius_px > 0 && detect_max_radius_px > detect_min_radius_px && detect_max_radius_px <= 32768))
    throw ConfigError(fmt::format("--detect-radius-px {},{}: expected 0 < min < max <= 32768 px",
                                  detect_min_radius_px, detect_max_radius_px));
  if (phase_bins < 0 || phase_bins > 360)
    throw ConfigError(fmt::format("--phase-bins {}: expected 0..360", phase_bins));
}

ProfileJobSummary run_profile_job(const ProfileJobOptions& o, const core::Metadata& header,
                                  const core::ProgressCallback& progress) {
  o.validate();
  auto src = open_fields(o.input, o.dt_s);
  ProfileJobSummary sum;

  // Geometry: given > attributes > detection.
  double cx = o.centre_x_px, cy = o.centre_y_px, R_px = o.cup_radius_px, Rv_px = o.vane_radius_px;
  sum.geometry_source = "given";
  if (!o.detect_cup_frame.empty() && (!set(cx) || !set(R_px))) {
    const double lo = set(o.detect_min_radius_px) ? o.detect_min_radius_px : 50.0;
    const double hi = set(o.detect_max_radius_px) ? o.detect_max_radius_px : 5000.0;
    const auto c = profile::detect_cup_circle(first_frame(o.detect_cup_frame), lo, hi);
    if (!set(cx)) {
      cx = c.centre_x_px;
      cy = c.centre_y_px;
    }
    if (!set(R_px)) R_px = c.radius_px;
    sum.geometry_source = fmt::format("rim detected in {} (rms {} px, {} edge px)", o.detect_cup_frame,
                                      format_number(c.rms_residual_px), c.edge_points);
  }
  if (!set(cx)) {
    cx = src->attribute("centre_x_px");
    cy = src->attribute("centre_y_px");
    sum.geometry_source = "field attributes";
  }
  if (!set(R_px)) R_px = src->attribute("cup_radius_px");
  if (!set(Rv_px)) Rv_px = src->attribute("vane_radius_px");
  if (!set(Rv_px)) Rv_px = 0.0;
  if (!set(cx) || !set(cy))
    throw ConfigError(fmt::format("{}: no cup centre: give --centre X Y or --detect-cup FRAME (the "
                                  "file has no centre_x_px/centre_y_px attributes)",
                                  o.input.string()));
  // Scale: every source there is, then one of them (see ProfileJobOptions).
  struct ScaleSource {
    const char* name;
    double m_per_px;
    std::string text;
  };
  std::vector<ScaleSource> scales;
  if (set(o.m_per_px))
    scales.push_back({"m-per-px", o.m_per_px, fmt::format("--m-per-px {}", format_number(o.m_per_px))});
  if (set(o.cup_radius_m) && set(R_px)) {
    const double m = profile::m_per_px_from_radius(o.cup_radius_m, R_px);
    scales.push_back({"cup-radius", m,
                      fmt::format("--cup-radius-m {} / R = {} px = {} m/px", format_number(o.cup_radius_m),
                                  format_number(R_px), fmt::format("{:.6g}", m))});
  }
  const double file_scale = src->attribute("m_per_px");
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
  if (!set(R_px)) {
    if (!set(o.cup_radius_m))
      throw ConfigError("no cup radius: give --radii-px RV,R, --detect-cup FRAME or --cup-radius-m");
    R_px = o.cup_radius_m / m_per_px;
  }
  profile::ProfileOptions po;
  po.centre_x_px = cx;
  po.centre_y_px = cy;
  po.m_per_px = m_per_px;
  po.r_min_m = Rv_px * m_per_px;
  po.r_max_m = R_px * m_per_px;
  po.bin_m = set(o.bin_m) ? o.bin_m : (set(o.bin_px) ? o.bin_px * m_per_px : 0.5 * o.bead_diameter_m);
  po.exclude_replaced = o.exclude_replaced;
  po.grouping = o.groups == "cycles"  ? profile::Grouping::kCycles
                : o.groups == "pairs" ? profile::Grouping::kPairsPhaseDetrended
                                      : profile::Grouping::kNone;
  po.validate();

  // Pair selection.
  const double f = set(o.f_Hz) ? o.f_Hz : src->attribute("f_Hz");
  const bool selecting =
      !o.cycles.empty() || o.phase_min_deg > 0 || o.phase_max_deg < 360 || o.phase_bins > 0;
  if (set(f) && !(f > 0 && f <= 1e6))
    throw InputError(fmt::format("{}: attribute f_Hz = {}: expected 0 < f <= 1e6 Hz", o.input.string(), f));
  if (selecting && !(f > 0))
    throw ConfigError("--cycles / --phase-range-deg / --phase-bins need the oscillation frequency: "
                      "give --f-hz (the field file has no f_Hz attribute)");
  const int nphase = std::max(1, o.phase_bins);
  const double phase_w = (o.phase_max_deg - o.phase_min_deg) / nphase;

  std::vector<profile::ProfileAccumulator> accs(static_cast<std::size_t>(nphase),
                                                profile::ProfileAccumulator(po));
  core::VectorField field;
  std::vector<double> dts;
  const std::size_t n = src->size();
  for (std::size_t k = 0; k < n; ++k) {
    double t_a = 0, dt = 0;
    src->read(k, field, t_a, dt);
    ++sum.pairs_read;
    int cycle = profile::PairSeries::kNoCycle;
    double phase = core::kUnset;
    std::size_t ph = 0;
    if (f > 0) {
      const auto cp = profile::cycle_phase(t_a + 0.5 * dt, f, o.t0_s);
      if (!o.cycles.empty() && std::find(o.cycles.begin(), o.cycles.end(), cp.cycle) == o.cycles.end())
        continue;
      if (cp.phase_deg < o.phase_min_deg || cp.phase_deg >= o.phase_max_deg) continue;
      cycle = cp.cycle;
      phase = cp.phase_deg / 360.0;
      ph = std::min(static_cast<std::size_t>(nphase - 1),
                    static_cast<std::size_t>((cp.phase_deg - o.phase_min_deg) / phase_w));
    }
    if (!(dt > 0))
      throw InputError(fmt::format("{}: pair {}: dt_s = {}: expected a positive time step",
                                   o.input.string(), k, dt));
    accs[ph].add(field, dt, cycle, phase);
    dts.push_back(dt);
    ++sum.pairs_used;
    if (progress) progress(k + 1, n);
  }
  if (sum.pairs_used == 0)
    throw NoResultError(fmt::format("{}: no pair selected ({} read): check --cycles, "
                                    "--phase-range-deg, --t0-s and f",
                                    o.input.string(), sum.pairs_read));
  const double dt_median = core::upper_median_inplace(dts);  // dts: all > 0, at least one

  // Noise floor: a static reference, or a region of each profile.
  std::unique_ptr<profile::ProfileAccumulator> racc;
  std::string noise_method;
  const double noise_lo = set(o.noise_min_m) ? o.noise_min_m : po.r_max_m - 0.15 * (po.r_max_m - po.r_min_m);
  const double noise_hi = set(o.noise_max_m) ? o.noise_max_m : po.r_max_m;
  if (!o.noise_ref.empty()) {
    auto ref = open_fields(o.noise_ref, o.dt_s);
    racc = std::make_unique<profile::ProfileAccumulator>(po);
    core::VectorField rf;
    for (std::size_t k = 0; k < ref->size(); ++k) {
      double t_a = 0, dt = 0;
      ref->read(k, rf, t_a, dt);
      // The reference is static: its displacements are noise in px per pair; convert
      // them with the time step of the measurement so that both floors compare.
      racc->add(rf, dt_median);
    }
    noise_method = fmt::format("mean |v| per bin of the static reference {} ({} pairs)",
                               o.noise_ref.string(), ref->size());
  } else {
    noise_method = fmt::format("sigma*sqrt(pi/2), sigma = scatter of v_r in {} <= r <= {} m",
                               format_number(noise_lo), format_number(noise_hi));
  }
  sum.centre_x_px = cx;
  sum.centre_y_px = cy;
  sum.m_per_px = m_per_px;
  sum.R_m = po.r_max_m;
  sum.Rv_m = po.r_min_m;
  sum.bin_m = po.bin_m;
  sum.bins = po.num_bins();

  core::Metadata meta = header;
  meta.emplace_back("input", o.input.string());
  meta.emplace_back("geometry_source", sum.geometry_source);
  meta.emplace_back("centre_x_px", format_number(cx));
  meta.emplace_back("centre_y_px", format_number(cy));
  meta.emplace_back("m_per_px", format_number(m_per_px));
  meta.emplace_back("scale_source", sum.scale_source);
  meta.emplace_back("Rv_m", format_number(po.r_min_m));
  meta.emplace_back("R_m", format_number(po.r_max_m));
  meta.emplace_back("bin_m", format_number(po.bin_m));
  meta.emplace_back("r_m", "bin centre; bin k covers [Rv + k bin, Rv + (k+1) bin)");
  meta.emplace_back("replaced_vectors", o.exclude_replaced ? "excluded (counted as invalid)" : "used");
  meta.emplace_back("f_Hz", set(f) ? format_number(f) : "unknown");
  meta.emplace_back("t0_s", format_number(o.t0_s));
  std::string cyc;
  for (int c : o.cycles) cyc += (cyc.empty() ? "" : ",") + std::to_string(c);
  meta.emplace_back("cycles", cyc.empty() ? "all" : cyc);
  meta.emplace_back("dt_s", format_number(dt_median));
  const double fps = src->attribute("fps");
  if (set(fps)) meta.emplace_back("fps", format_number(fps));
  meta.emplace_back("noise_method", noise_method);
  for (const char* tag : {"N", "phi0_rad"}) {
    const std::string v = src->text_attribute(tag);
    if (!v.empty()) meta.emplace_back(tag, v);
  }
  meta.emplace_back("v_abs_sem_m_per_s",
                    "standard deviation of 1000 bootstrap replicates of the bin mean (seed 1) under "
                    "`groups`; empty with a single pair");
  meta.emplace_back("empty_cells", "a bin without vectors (n_vectors = 0) has no velocity values");

  // One profile (and its groups file) per phase bin; all appear together or none.
  std::vector<std::unique_ptr<io::AtomicOutput>> outs;
  for (int ph = 0; ph < nphase; ++ph) {
    std::filesystem::path path = o.output;
    if (nphase > 1)
      path = o.output.parent_path() /
             fmt::format("{}_phase{:02d}{}", o.output.stem().string(), ph, o.output.extension().string());
    const std::filesystem::path gpath = io::profile_groups_path(path);
    const auto& acc = accs[static_cast<std::size_t>(ph)];
    const double plo = o.phase_min_deg + ph * phase_w, phi = plo + phase_w;
    if (acc.num_pairs() == 0)
      throw NoResultError(fmt::format("{}: no pair in phase bin {} ({}-{} deg): use fewer --phase-bins",
                                      o.input.string(), ph, format_number(plo), format_number(phi)));
    const profile::RadialProfile p = racc ? acc.finish_with_reference_noise(*racc)
                                          : acc.finish_with_region_noise(noise_lo, noise_hi);
    sum.groups += p.n_groups;
    if (ph == 0) {
      sum.noise_floor_m_per_s = p.bins.empty() ? 0 : p.bins.front().v_noise;
      sum.grouping = profile::grouping_name(p.grouping);
      sum.rho = p.rho;
    }
    core::Metadata m = meta;
    m.emplace_back("phase_range_deg", format_number(plo) + "," + format_number(phi));
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
    outs.push_back(std::make_unique<io::AtomicOutput>(path, o.force));
    {
      std::vector<io::ProfileCsvRow> rows;
      for (const auto& b : p.bins)
        rows.push_back({b.r_m, b.v_abs, b.v_theta, b.v_r, b.v_abs_rms, b.v_abs_sem, b.v_noise, b.n_vectors,
                        b.n_masked, b.n_invalid});
      io::write_profile_csv(outs.back()->stream(), m, rows);
    }
    outs.push_back(std::make_unique<io::AtomicOutput>(gpath, o.force));
    {
      core::Metadata gm = header;
      gm.emplace_back("profile", path.filename().string());
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
          g.r_m = p.bins[b].r_m;
          g.v_abs = ps.v_abs[k * ps.n_bins + b];
          g.n_vectors = nv;
          rows.push_back(g);
        }
      io::write_profile_groups_csv(outs.back()->stream(), gm, rows);
    }
  }
  for (auto& out : outs) out->commit();
  return sum;
}

}  // namespace shearzone::pipeline
