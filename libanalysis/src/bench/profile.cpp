#include "shearzone/bench/profile.hpp"

#include <sys/resource.h>

#include <chrono>
#include <cmath>
#include <fstream>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/io/atomic_output.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/io/field_file.hpp"
#include "shearzone/pipeline/profile_job.hpp"
#include "shearzone/pipeline/width_job.hpp"
#include "shearzone/synth/zone_fields.hpp"

namespace shearzone::bench {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

/// Peak resident memory of this process so far, MB.
double peak_rss_mb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;  // Linux: kB
}

/// Resident memory now, MB.
double rss_now_mb() {
  std::ifstream f("/proc/self/statm");
  double pages = 0, resident = 0;
  f >> pages >> resident;
  return resident * 4096.0 / (1024.0 * 1024.0);
}

constexpr double kVc = 4e-5;
constexpr double kRcTrue = 0.02097;

}  // namespace

void BenchProfileOptions::validate() const {
  if (pairs < 12 || pairs > 1000000)
    throw ConfigError(fmt::format("--pairs {}: expected 12..1000000", pairs));
  if (!(spacing_px >= 2 && spacing_px <= 256))
    throw ConfigError(fmt::format("--spacing-px {}: expected 2..256", spacing_px));
  if (!(width_px >= 688 && height_px >= 688 && width_px <= 8192 && height_px <= 8192))
    throw ConfigError(fmt::format("--width/--height {}x{}: expected 688..8192 px (the 34 mm cup is 680 px across)",
                                  width_px, height_px));
  if (!(f_Hz > 0 && f_Hz <= 5)) throw ConfigError(fmt::format("--f-hz {}: expected 0 < f <= 5 Hz", f_Hz));
  if (!(noise_px >= 0 && noise_px <= 1)) throw ConfigError(fmt::format("--noise-px {}: expected 0..1", noise_px));
  if (out_dir.empty()) throw ConfigError("bench profile: no output folder");
}

BenchProfileSummary run_profile_bench(const BenchProfileOptions& o, const core::Metadata& header,
                                      const core::ProgressCallback& progress) {
  o.validate();
  std::filesystem::create_directories(o.out_dir);
  const auto csv_path = o.out_dir / "profile_bench.csv";
  io::check_output_allowed(csv_path, o.force);
  BenchProfileSummary sum;

  synth::ZoneFieldOptions z;
  z.width_px = o.width_px;
  z.height_px = o.height_px;
  z.centre_x_px = 0.5 * o.width_px - 0.5;
  z.centre_y_px = 0.5 * o.height_px - 0.5;
  z.spacing_px = o.spacing_px;
  z.f_Hz = o.f_Hz;
  z.noise_px = o.noise_px;
  // V0 such that the cycle mean of |v_theta| crosses v_c at the paper-scale r_c.
  z.v0_m_per_s = kVc / synth::zone_waveform_mean_abs(z) * std::exp((kRcTrue - z.vane_radius_m) / z.lambda_m);
  z.validate();
  const double rc_true = synth::zone_true_rc(z, kVc);

  // 1. The clip's fields, generated in batches (parallel) and appended in order.
  const auto fields = o.out_dir / "zone_fields.h5";
  std::filesystem::remove(fields);
  const auto t_gen = Clock::now();
  std::size_t vectors_per_pair = 0;
  {
    io::FieldFileWriter w(fields);
    constexpr int kBatch = 32;
    std::vector<core::VectorField> batch(kBatch);
    for (int k0 = 0; k0 < o.pairs; k0 += kBatch) {
      const int n = std::min(kBatch, o.pairs - k0);
#pragma omp parallel for schedule(static)
      for (int i = 0; i < n; ++i) batch[static_cast<std::size_t>(i)] = synth::zone_pair(z, static_cast<std::size_t>(k0 + i));
      for (int i = 0; i < n; ++i) {
        const int k = k0 + i;
        w.append(batch[static_cast<std::size_t>(i)], k, k + 1, k / z.fps, 1.0 / z.fps);
      }
      vectors_per_pair = batch[0].size();
      if (progress) progress(static_cast<std::size_t>(k0 + n), static_cast<std::size_t>(2 * o.pairs));
    }
    w.set_attribute("fps", z.fps);
    w.set_attribute("m_per_px", z.m_per_px);
    w.set_attribute("f_Hz", z.f_Hz);
    w.set_attribute("vane_phase_rad", 0.0);
    w.set_attribute("centre_x_px", z.centre_x_px);
    w.set_attribute("centre_y_px", z.centre_y_px);
    w.set_attribute("source", "shearzone bench profile (synth/zone_fields.hpp)");
    w.close();
  }
  const double gen_s = seconds_since(t_gen);
  const double file_mb = static_cast<double>(std::filesystem::file_size(fields)) / (1024.0 * 1024.0);

  // 2. profile, streamed.
  pipeline::ProfileJobOptions po;
  po.input = fields;
  po.output = o.out_dir / "profile.csv";
  po.force = true;
  po.vane_radius_px = z.vane_radius_m / z.m_per_px;
  po.cup_radius_px = z.cup_radius_m / z.m_per_px;
  po.lockin_harmonics = o.lockin_harmonics;
  const double rss_before = rss_now_mb();
  const auto t_prof = Clock::now();
  const auto psum = pipeline::run_profile_job(po, header, [&](std::size_t done, std::size_t total) {
    if (progress) progress(static_cast<std::size_t>(o.pairs) + done * static_cast<std::size_t>(o.pairs) / total,
                           static_cast<std::size_t>(2 * o.pairs));
  });
  const double prof_s = seconds_since(t_prof);
  const double peak = peak_rss_mb();
  sum.files.push_back(po.output);
  if (!o.keep_fields) std::filesystem::remove(fields);
  else sum.files.push_back(fields);

  // 3. width with each estimator.
  io::AtomicOutput out(csv_path, o.force);
  core::Metadata meta = header;
  meta.emplace_back("clip", fmt::format("{} pairs of {}x{} px on a {} px grid ({} vectors per pair), {} m/px, {} fps, "
                                        "f = {} Hz, noise {} px per component, waveform {}",
                                        o.pairs, o.width_px, o.height_px, io::format_number(o.spacing_px),
                                        vectors_per_pair, io::format_number(z.m_per_px), io::format_number(z.fps),
                                        io::format_number(z.f_Hz), io::format_number(z.noise_px),
                                        synth::zone_waveform_name(z.waveform)));
  meta.emplace_back("zone", fmt::format("v_theta = V0 exp(-(r - Rv)/lambda) cos(2 pi f t), Rv = {} m, R = {} m, lambda = {} m, "
                                        "V0 = {} m/s",
                                        io::format_number(z.vane_radius_m), io::format_number(z.cup_radius_m),
                                        io::format_number(z.lambda_m), io::format_number(z.v0_m_per_s)));
  meta.emplace_back("v_c_m_per_s", io::format_number(kVc));
  meta.emplace_back("generate_s", "wall time to generate and write the field file (not part of the analysis)");
  meta.emplace_back("profile_s", "wall time of `shearzone profile` on the file (streamed, pair by pair)");
  meta.emplace_back("peak_rss_MB", "peak resident memory of the process after profile (the generator streams: "
                                   "rss_before_profile_MB is what it left)");
  io::CsvWriter w(out.stream(), meta,
                  {"pairs", "vectors_per_pair", "field_file_MB", "generate_s", "profile_s", "rss_before_profile_MB",
                   "peak_rss_MB", "estimator", "width_s", "rc_m", "rc_ci_low_m", "rc_ci_high_m", "rc_status",
                   "rc_true_m", "rc_error_m", "v_noise_m_per_s", "lockin_harmonics"});
  for (const char* est : {"mean-abs", "lockin"}) {
    pipeline::WidthJobOptions wo;
    wo.inputs = {po.output};
    wo.output = o.out_dir / fmt::format("widths_{}.csv", est);
    wo.force = true;
    wo.width.v_c_m_per_s = kVc;
    wo.width.estimator = profile::estimator_from_name(est);
    const auto t_w = Clock::now();
    pipeline::run_width_job(wo, header);
    const double w_s = seconds_since(t_w);
    sum.files.push_back(wo.output);
    const auto t = io::read_csv(wo.output);
    const std::size_t c_rc = t.column_index("rc_m");
    const double rc = t.cell_empty(0, c_rc) ? core::kUnset : t.number(0, c_rc);
    auto cell = [&](const char* col) { return t.text_column(col)[0]; };
    w.row(std::vector<std::string>{std::to_string(o.pairs), std::to_string(vectors_per_pair),
                                   fmt::format("{:.1f}", file_mb), fmt::format("{:.2f}", gen_s),
                                   fmt::format("{:.2f}", prof_s), fmt::format("{:.1f}", rss_before),
                                   fmt::format("{:.1f}", peak), cell("estimator"), fmt::format("{:.3f}", w_s),
                                   cell("rc_m"), cell("rc_ci_low_m"), cell("rc_ci_high_m"), cell("rc_status"),
                                   io::format_number(rc_true),
                                   std::isfinite(rc) ? io::format_number(rc - rc_true) : std::string(),
                                   cell("v_noise_m_per_s"), std::to_string(o.lockin_harmonics)});
    sum.lines.push_back(fmt::format(
        "{:>8}: r_c {} (true {:.5g} m, {}), profile {:.1f} s and {:.0f} MB peak for {} pairs of {} vectors",
        cell("estimator"), std::isfinite(rc) ? fmt::format("{:.5g} m", rc) : std::string("none"), rc_true,
        cell("rc_status"), prof_s, peak, o.pairs, vectors_per_pair));
  }
  (void)psum;
  out.commit();
  sum.files.insert(sum.files.begin(), csv_path);
  return sum;
}

}  // namespace shearzone::bench
