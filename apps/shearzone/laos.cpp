// `shearzone laos`: oscillation logs -> harmonics, tan δ, Chebyshev measures per
// amplitude (CSV folder). Flags map onto pipeline::LaosJobOptions; --config FILE.toml
// sets them.
#include <cmath>
#include <cstdio>
#include <memory>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/pipeline/laos_job.hpp"
#include "subcommands.hpp"

namespace shearzone::apps {
namespace {

struct LaosCli {
  pipeline::LaosJobOptions job;
  std::vector<std::string> inputs, tags, cycles;
  std::string output, config, format = "auto", strain_col, stress_col;
  bool no_drift = false, no_split = false, inspect = false;
};

int run_laos(CLI::App& c, LaosCli& s, const Context& ctx) {
  configure(c, s.config, {});
  auto& j = s.job;
  for (const auto& p : s.inputs) j.inputs.emplace_back(p);
  j.output = s.output;
  for (auto& kv : parse_key_values(s.tags, "--tag")) j.tags.push_back(std::move(kv));
  j.read.format = io::log_format_from_name(s.format);
  if (!s.strain_col.empty() || !s.stress_col.empty()) {
    if (s.strain_col.empty() || s.stress_col.empty())
      throw ConfigError("--strain and --stress go together; expected both column names");
    j.read.quantity = io::LogQuantity::kStrainStress;
    j.read.angle_column = s.strain_col;
    j.read.torque_column = s.stress_col;
  }
  j.analysis.drift = !s.no_drift;
  j.analysis.split_amplitudes = !s.no_split;
  for (const auto& cy : s.cycles) {
    if (cy == "all") {
      j.analysis.all_cycles = true;
      continue;
    }
    std::size_t used = 0;
    int v = 0;
    try {
      v = std::stoi(cy, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != cy.size() || v < 1)
      throw ConfigError(fmt::format("--cycles \"{}\": expected cycle numbers >= 1 or \"all\"", cy));
    j.analysis.cycles.push_back(v);
  }
  for (const char* o : {"--spp-harmonics", "--spp-tolerance"})
    if (c.get_option(o)->count() > 0 && !j.spp)
      throw ConfigError(fmt::format("{} sets the SPP analysis; expected it with --spp", o));
  if (s.inspect) {
    std::fputs(pipeline::inspect_laos_logs(j).c_str(), stdout);
    return kExitOk;
  }
  if (ctx.capture) {  // the Python module's arrays: the options, no file
    ctx.capture(j);
    return kExitOk;
  }
  if (ctx.check_options) {  // the study's option check: no file read
    j.validate();
    return kExitOk;
  }
  require_option(c, "output");
  const auto sum = pipeline::run_laos_job(j, ctx.header());
  if (ctx.level != core::LogLevel::kQuiet) {
    const bool ss = sum.stress_strain;
    std::printf("laos: %zu log%s, %zu amplitude%s%s -> %s\n", sum.logs, sum.logs == 1 ? "" : "s",
                sum.rows.size(), sum.rows.size() == 1 ? "" : "s",
                sum.skipped_blocks ? fmt::format(" ({} ramp block(s) without a complete cycle skipped)",
                                                 sum.skipped_blocks)
                                         .c_str()
                                   : "",
                j.output.string().c_str());
    // The log column only when several logs are given.
    const bool many = sum.logs > 1;
    // The segment column as wide as its longest label (vendor labels such as
    // "LAOS 1 / interval 2 / point 1" were cut to "LAOS 1 / i"), 10 to 48 characters.
    constexpr std::size_t kMinSegment = 10, kMaxSegment = 48;
    std::size_t seg_width = kMinSegment;
    for (const auto& r : sum.rows) seg_width = std::max(seg_width, std::min(kMaxSegment, r.segment.size()));
    const auto segment_cell = [&](const std::string& text) {
      return fmt::format("{:<{}.{}}", text, seg_width, seg_width);
    };
    std::printf("  %3s %s%s %10s %11s %11s %11s %9s %8s %6s %3s %6s  %s\n", "#",
                many ? fmt::format("{:<16.16s} ", "log").c_str() : "", segment_cell("segment").c_str(),
                ss ? "gamma0" : "phi0/rad", ss ? "sig_max/Pa" : "tau_max/Nm", ss ? "G'1/Pa" : "K'1/Nm/rad",
                ss ? "G''1/Pa" : "K''1/Nm/rad", "tan_d", "I3/I1", "phi_d", "M", "cycles", "status");
    for (const auto& r : sum.rows)
      std::printf("  %3zu %s%s %10.4g %11.4g %11.4g %11.4g %9.4g %8.3g %6.3f %3d %3d/%-2d  %s\n",
                  r.amplitude,
                  many ? fmt::format("{:<16.16s} ", std::filesystem::path(r.source).filename().string()).c_str()
                       : "",
                  segment_cell(r.segment).c_str(), r.x0, r.r_max, r.K1p, r.K1pp, r.tan_delta,
                  r.I3_over_I1, r.phi_d, r.M, r.cycles_used, r.cycles_complete, laos::amplitude_status_name(r.status));
    if (j.spp) {
      // A measure not given shows its status in place of the value.
      const auto cell = [](const laos::SppMeasure& m) {
        return m.status == laos::SppStatus::kOk ? fmt::format("{:.4g}", m.value)
                                                : std::string(laos::spp_status_name(m.status));
      };
      std::printf("  spp (spp_summary.csv): %3s %4s %18s %19s %19s\n", "#", "M", ss ? "cage/Pa" : "cage/Nm/rad",
                  ss ? "static_yield/Pa" : "static_yield/Nm", ss ? "dynamic_yield/Pa" : "dynamic_yield/Nm");
      for (std::size_t i = 0; i < sum.spp_rows.size(); ++i) {
        const auto& r = sum.spp_rows[i];
        if (r.M == 0) {
          std::printf("  %27zu  too coarse for the third harmonic (spp_summary.csv)\n", i + 1);
          continue;
        }
        std::printf("  %27zu %4d %18s %19s %19s\n", i + 1, r.M, cell(r.cage).c_str(), cell(r.static_yield).c_str(),
                    cell(r.dynamic_yield).c_str());
      }
    }
  }
  return kExitOk;
}

}  // namespace

std::vector<Subcommand> add_laos(CLI::App& root, Context& ctx) {
  auto s = std::make_shared<LaosCli>();
  auto& j = s->job;
  CLI::App* c = root.add_subcommand(
      "laos", "LAOS analysis of torque/angle logs: harmonics, tan delta, Chebyshev measures -> CSVs");
  c->add_option("logs", s->inputs, "Oscillation logs (CSV/TSV, RheoCompass, TRIOS, RepTate .laos)")
      ->required();
  c->add_option("-o,--output", s->output, "Output folder (summary.csv, cycles.csv, harmonics.csv, lissajous_NN.csv)");
  c->add_option("--config", s->config, "TOML file setting any of these options by long name");
  c->add_flag("--force", j.force, "Replace existing outputs");
  c->add_option("--tag", s->tags, "KEY=VALUE for every summary row (N=45: chain length)");
  // Reading
  c->add_option("--format", s->format, "auto, csv, anton-paar, trios, reptate, malvern")->capture_default_str();
  c->add_option("--time-col", j.read.time_column, "Time column of a CSV log (empty: none)")
      ->capture_default_str();
  c->add_option("--angle-col", j.read.angle_column, "Angle column of a CSV log")->capture_default_str();
  c->add_option("--torque-col", j.read.torque_column, "Torque column of a CSV log")
      ->capture_default_str();
  c->add_option("--interval-col", j.read.interval_column, "Column whose changes start a new segment");
  c->add_option("--time-unit", j.read.time_unit, "s or ms (default: from the column name)");
  c->add_option("--angle-unit", j.read.angle_unit, "rad, mrad or deg (or strain: 1, %)");
  c->add_option("--torque-unit", j.read.torque_unit, "N m, mN m or uN m (or stress: Pa)");
  c->add_option("--strain", s->strain_col, "Strain column: strain/stress mode (moduli in Pa)");
  c->add_option("--stress", s->stress_col, "Stress column (Pa) for strain/stress mode");
  // Analysis
  c->add_option("-M,--harmonics", j.analysis.max_harmonic,
                "Highest harmonic M (capped by the sampling); range: 1..200")
      ->capture_default_str();
  c->add_option("--cycles", s->cycles,
                "Cycles to analyse, 1-based, e.g. 3,4,5, or all (default: steady); "
                "range: integers 1..complete cycles of the amplitude, or all")
      ->delimiter(',');
  c->add_option("--steady-tol", j.analysis.steady_tolerance,
                "Steady state: relative cycle-to-cycle change of K'1 and K''1 below this; range: > 0")
      ->capture_default_str();
  c->add_option("--amplitude-change", j.analysis.amplitude_change,
                "New amplitude when a cycle's phi0 changes by more than this fraction; range: 0 < x < 1")
      ->capture_default_str();
  c->add_flag("--no-split", s->no_split, "Treat each segment as one amplitude");
  c->add_flag("--inspect", s->inspect,
              "Print what each log holds (format, segments with lines and samples, skipped "
              "blocks and why) and write nothing; -o is not needed");
  c->add_option("--max-drive-misfit", j.analysis.max_drive_misfit,
                "Largest rms misfit of the drive's sine fit, fraction of its amplitude, for a "
                "steady oscillation (above: exit 3); range: > 0")
      ->capture_default_str();
  c->add_option("--max-amplitude-spread", j.analysis.max_amplitude_spread,
                "Largest spread max/min - 1 of the used cycles' drive amplitudes (above: exit "
                "3); range: > 0")
      ->capture_default_str();
  c->add_flag("--force-one-amplitude", j.analysis.force_one_amplitude,
              "With --no-split: analyse even when the raw cycles' amplitudes differ by more "
              "than --amplitude-change");
  c->add_flag("--no-drift", s->no_drift, "No linear-drift column in the harmonic fit");
  c->add_option("--f-hz", j.f_Hz,
                "Drive frequency, Hz (default: the log's; fitted when time is logged); "
                "range: > 0, finite");
  c->add_option("--inertia-kg-m2", j.inertia_kg_m2,
                "Instrument inertia I: analyse tau - I phi''; range: >= 0, finite");
  c->add_option("--stress-constant", j.stress_constant_Pa_per_N_m,
                "Vane stress constant, Pa/(N m): outputs in stress/strain; "
                "range: > 0 (with --strain-constant)");
  c->add_option("--strain-constant", j.strain_constant_per_rad,
                "Vane strain constant, 1/rad; range: > 0 (with --stress-constant)");
  c->add_flag("--log-constants", j.log_constants, "Stress/strain constants from the log (TRIOS)");
  c->add_flag("--spp", j.spp,
              "Within the cycle (sequence of physical processes): transient moduli per sample (spp_NN.csv), "
              "cage modulus and yield stresses per amplitude (spp_summary.csv)");
  c->add_option("--spp-harmonics", j.spp_options.max_harmonic,
                "SPP: highest odd harmonic of the response (capped by the sampling); range: 3..999")
      ->capture_default_str();
  c->add_option("--spp-tolerance", j.spp_options.max_relative_change,
                "SPP: largest noise spread or truncation change of a cycle measure, as a fraction of it, for "
                "the measure to be given; range: 0 < x < 1")
      ->capture_default_str();
  return {{c, [c, s, &ctx] { return run_laos(*c, *s, ctx); }}};
}

}  // namespace shearzone::apps
