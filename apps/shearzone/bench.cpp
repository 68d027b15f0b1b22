// `shearzone bench piv`: the PIV speed-accuracy chart and failure map (CSV).
// `shearzone bench profile`: profile and width on a long synthetic clip: time, memory, r_c.
// `shearzone bench sim`: engine speed against bead count, accuracy against h and the cap.
// `shearzone bench track`: the bead tracker's speed against accuracy on 1080p truth (CSV).
#include <cstdio>
#include <memory>

#include "shearzone/bench/piv.hpp"
#include "shearzone/bench/profile.hpp"
#include "shearzone/bench/sim.hpp"
#include "shearzone/bench/track.hpp"
#include "subcommands.hpp"

namespace shearzone::apps {
namespace {

/// Runs a benchmark with its progress on the terminal, then lists the files it wrote
/// and its summary lines (`lines`, where the summary has them).
template <class Run>
auto run_bench(Context& ctx, const char* name, Run run) {
  core::ProgressReporter progress(name, ctx.level);
  auto sum = run(progress.callback());
  progress.finish();
  if (ctx.level != core::LogLevel::kQuiet) {
    for (const auto& f : sum.files) std::printf("wrote %s\n", f.string().c_str());
    if constexpr (requires { sum.lines; })
      for (const auto& l : sum.lines) std::printf("%s\n", l.c_str());
  }
  return sum;
}

}  // namespace

std::vector<Subcommand> add_bench(CLI::App& root, Context& ctx) {
  CLI::App* bench = root.add_subcommand("bench", "Benchmarks: speed against accuracy, as CSV");
  bench->require_subcommand(1);
  auto o = std::make_shared<bench::BenchPivOptions>();
  auto out = std::make_shared<std::string>();
  CLI::App* p = bench->add_subcommand("piv", "PIV settings grid on 1080p truth + failure map");
  p->add_option("-o,--output", *out, "Output folder for the CSV files")->required();
  p->add_flag("--force", o->force, "Replace existing files");
  p->add_flag("--quick", o->quick, "Small grid on 960x540 (a smoke run)");
  p->add_option("--repeats", o->timing_repeats, "Timed runs per setting (median); range: 1..1000")
      ->capture_default_str();
  p->add_option("--width", o->width_px, "Pair width, px; range: 8..8192")->capture_default_str();
  p->add_option("--height", o->height_px, "Pair height, px; range: 8..8192")->capture_default_str();
  auto po = std::make_shared<bench::BenchProfileOptions>();
  auto pout = std::make_shared<std::string>();
  CLI::App* pr = bench->add_subcommand(
      "profile", "profile + width on a long synthetic clip (default: 4 min of 1080p): time, memory, r_c vs truth");
  pr->add_option("-o,--output", *pout, "Output folder for the CSV files")->required();
  pr->add_flag("--force", po->force, "Replace existing files");
  pr->add_option("--pairs", po->pairs, "Pairs of the clip (25 per second); range: 12..1000000")->capture_default_str();
  pr->add_option("--spacing-px", po->spacing_px, "PIV grid step, px; range: 2..256")->capture_default_str();
  pr->add_option("--width", po->width_px, "Frame width, px; range: 688..8192")->capture_default_str();
  pr->add_option("--height", po->height_px, "Frame height, px; range: 688..8192")->capture_default_str();
  pr->add_option("--f-hz", po->f_Hz, "Drive frequency, Hz; range: 0 < f <= 5")->capture_default_str();
  pr->add_option("--noise-px", po->noise_px, "PIV noise per component, px; range: 0..1")->capture_default_str();
  pr->add_option("--lockin-harmonics", po->lockin_harmonics, "Lock-in harmonics (as profile); range: 0 or odd 1..31")
      ->capture_default_str();
  pr->add_flag("--keep-fields", po->keep_fields, "Keep the generated zone_fields.h5 (about 10 bytes per vector)");
  auto to = std::make_shared<bench::BenchTrackOptions>();
  auto tout = std::make_shared<std::string>();
  CLI::App* t = bench->add_subcommand("track", "Bead tracking on 1080p truth: time and error per bead size");
  t->add_option("-o,--output", *tout, "Output folder for the CSV file")->required();
  t->add_flag("--force", to->force, "Replace existing files");
  t->add_flag("--quick", to->quick, "960x540 pair of 35 px beads (a smoke run)");
  t->add_option("--repeats", to->timing_repeats, "Timed runs per bead size (median); range: 1..1000")
      ->capture_default_str();
  t->add_option("--width", to->width_px, "Pair width, px; range: 64..8192")->capture_default_str();
  t->add_option("--height", to->height_px, "Pair height, px; range: 64..8192")->capture_default_str();
  t->add_option("--threads", to->threads, "Pairs tracked at a time in the clip's throughput, one per thread (0: all "
                                         "cores); range: 0..1024")
      ->capture_default_str();
  t->add_option("--clip-pairs", to->clip_pairs, "Pairs per timed clip; range: 1..10000")->capture_default_str();
  t->add_option("--diameters", to->diameters_px, "Bead diameters, px; range: each 3..200, at most a quarter of the "
                                                 "shorter side")
      ->delimiter(',')
      ->capture_default_str();
  auto so = std::make_shared<bench::BenchSimOptions>();
  auto sout = std::make_shared<std::string>();
  CLI::App* s = bench->add_subcommand("sim", "Contact-dynamics engine: speed vs beads, accuracy vs h and cap; "
                                             "--scene cup: the sheared vane cup");
  s->add_option("-o,--output", *sout, "Output folder for the CSV files")->required();
  s->add_flag("--force", so->force, "Replace existing files");
  s->add_flag("--quick", so->quick, "Small packings and few steps (a smoke run)");
  s->add_option("--beads", so->beads,
                "Bead counts of the speed table; range: 1 to 32 counts, each 1..1000000")
      ->delimiter(',')
      ->capture_default_str();
  s->add_option("--threads", so->threads,
                "Engine thread counts of the speed table (slab-parallel sweep); "
                "range: 1 to 32 counts, each 1..256")
      ->delimiter(',')
      ->capture_default_str();
  s->add_option("--time-step", so->time_step_s,
                "h of the speed table and the relaxation, s; range: 0 < h <= 0.1")
      ->capture_default_str();
  s->add_option("--tolerance", so->tolerance, "NLGS residual tolerance; range: > 0")->capture_default_str();
  s->add_option("--max-iterations", so->max_iterations,
                "NLGS sweep cap of the speed table; range: 1..100000")
      ->capture_default_str();
  s->add_option("--freeze-sweeps", so->freeze_sweeps,
                "Sweeps a quiet row stays frozen (0: off); range: 0..1000000")
      ->capture_default_str();
  s->add_option("--relax-steps", so->relax_max_steps,
                "Most relaxation steps before timing; range: 0..1000000")
      ->capture_default_str();
  s->add_option("--steps", so->steps, "Timed steps per bead count; range: 1..100000")->capture_default_str();
  s->add_option("--solver", so->solvers,
                "Engine solvers: alternate (NLGS, forward and backward sweeps), forward (NLGS, forward sweeps), "
                "anderson (forward sweeps + Anderson acceleration); the packing tables use the first, --scene times "
                "each")
      ->delimiter(',')
      ->check(CLI::IsMember({"alternate", "forward", "anderson"}))
      ->capture_default_str();
  s->add_option("--anderson-depth", so->anderson_depth, "Columns of --solver anderson; range: 1..10")
      ->capture_default_str();
  s->add_option("--warmup-steps", so->warmup_steps, "Untimed steps before the timing; range: 0..100000")
      ->capture_default_str();
  s->add_option("--scene", so->scene,
                "Shear a vane cup instead: cup (the paper's cup, sim_cup.csv) or a scene .toml with a [vane]; "
                "stir: the peer benchmark's stirred box (sim_stir.csv); plow: the box plowed by a full-height wall "
                "(sim_plow.csv)");
  s->add_option("--N", so->chain_lengths, "Chain lengths of --scene cup; range: 1 to 32 values, each 1..1000")
      ->delimiter(',')
      ->capture_default_str();
  s->add_option("--cup-beads", so->cup_beads, "Beads of --scene cup; range: 10..1000000")->capture_default_str();
  s->add_option("--stir-beads", so->stir_beads, "Beads of --scene stir; range: 10..1000000")->capture_default_str();
  s->add_option("--phi0", so->phi0_rad, "Vane amplitude of --scene, rad; range: 0 < phi0 <= 100")
      ->capture_default_str();
  s->add_option("--f-hz", so->f_Hz, "Vane frequency of --scene, Hz; range: 0 < f <= 1000")->capture_default_str();
  s->add_flag("--accuracy", so->cup_accuracy,
              "With --scene cup or a scene .toml: the observables (torque amplitude, K'1, K''1, r_c, overlap) "
              "against the solver's tolerance and time step (sim_cup_accuracy.csv)");
  s->add_option("--tolerances", so->cup_tolerances, "Tolerances of --accuracy; range: 1 to 16 values in (0, 1]")
      ->delimiter(',')
      ->capture_default_str();
  s->add_option("--time-steps", so->cup_time_steps_s, "Time steps of --accuracy, s; range: 1 to 16 values in (0, 0.1]")
      ->delimiter(',')
      ->capture_default_str();
  s->add_option("--cycles", so->cycles, "Drive cycles per setting of --accuracy; range: 1..1000")->capture_default_str();
  s->add_option("--preshear-cycles", so->preshear_cycles,
                "Cycles at --time-step and --tolerance before the settings of --accuracy; range: 0..1000")
      ->capture_default_str();
  s->add_option("--sectors", so->cup_sectors,
                "--scene cup as a periodic wedge of 1/K of the cup with one blade (torques the whole cup's); range: "
                "1 (the whole cup) or 4")
      ->capture_default_str();
  s->add_flag("--sector-check", so->sector_check,
              "With --scene cup: the periodic quarter against the whole cup, per N and fill seed (sim_cup_sector.csv)");
  s->add_option("--reference", so->sector_reference,
                "With --sector-check: take the whole cup's rows from this earlier sim_cup_sector.csv (same protocol, "
                "beads, N and seeds) instead of running it again");
  s->add_option("--seeds", so->seeds, "Fill seeds of --sector-check; range: 1 to 32 seeds")
      ->delimiter(',')
      ->capture_default_str();
  s->add_option("--accuracy-cap", so->accuracy_cap, "Sweep cap of --accuracy (cap hits are counted); range: 1..100000")
      ->capture_default_str();
  s->add_option("--accuracy-beads", so->accuracy_beads,
                "Bead count of the accuracy packing; range: 1..1000000")
      ->capture_default_str();
  return {{p, [o, out, &ctx] {
             o->out_dir = *out;
             const auto sum = run_bench(ctx, "bench piv", [&](auto cb) { return bench::run_piv_bench(*o, ctx.header(), cb); });
             if (ctx.level != core::LogLevel::kQuiet) {
               if (!sum.best_line.empty()) std::printf("%s\n", sum.best_line.c_str());
               std::printf("plot: /usr/bin/python3 scripts/plot_bench_piv.py %s\n", o->out_dir.string().c_str());
             }
             return kExitOk;
           }},
          {pr, [po, pout, &ctx] {
             po->out_dir = *pout;
             (void)run_bench(ctx, "bench profile", [&](auto cb) { return bench::run_profile_bench(*po, ctx.header(), cb); });
             return kExitOk;
           }},
          {t, [to, tout, &ctx] {
             to->out_dir = *tout;
             (void)run_bench(ctx, "bench track", [&](auto cb) { return bench::run_track_bench(*to, ctx.header(), cb); });
             return kExitOk;
           }},
          {s, [so, sout, &ctx] {
             so->out_dir = *sout;
             (void)run_bench(ctx, "bench sim", [&](auto cb) { return bench::run_sim_bench(*so, ctx.header(), cb); });
             if (ctx.level != core::LogLevel::kQuiet && so->scene.empty())
               std::printf("plot: /usr/bin/python3 scripts/plot_bench_sim.py %s\n", so->out_dir.string().c_str());
             return kExitOk;
           }}};
}

}  // namespace shearzone::apps
