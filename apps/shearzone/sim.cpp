// `shearzone sim`: a contact-dynamics scene (TOML) -> snapshots (HDF5 + XDMF),
// checkpoints and the diagnostics CSV in one folder. Flags map onto
// pipeline::SimJobOptions; the scene keys are in shearzone/pipeline/sim_job.hpp.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "shearzone/pipeline/sim_job.hpp"
#include "subcommands.hpp"

namespace shearzone::apps {
namespace {

struct SimCli {
  pipeline::SimJobOptions job;
  std::string scene, output, restart;
};

void print_summary(const pipeline::SimJobSummary& sum, const std::string& output, const Context& ctx) {
  if (ctx.level != core::LogLevel::kQuiet) {
    if (sum.fill.settled)
      std::printf("sim: fill settled: %lld drop steps (%lld iteration-cap hits%s), %lld relaxation steps, "
                  "%s (kinetic energy %.3g m g d per bead) in %.3g s; the run starts from it at step 0\n",
                  static_cast<long long>(sum.fill.settle_steps),
                  static_cast<long long>(sum.fill.settle_cap_hits),
                  sum.fill.settle_plateau ? "; ended on its kinetic-energy plateau" : "",
                  static_cast<long long>(sum.fill.relax_steps),
                  sum.fill.relaxed ? "relaxed" : "NOT relaxed (fill.relax_max_steps reached)",
                  sum.fill.kinetic_energy, sum.fill.seconds);
    std::string kinds;
    if (sum.fixed_bodies > 0 || sum.kinematic_bodies > 0)
      kinds = " (" + std::to_string(sum.fixed_bodies) + " fixed, " + std::to_string(sum.kinematic_bodies) +
              " kinematic)";
    std::printf("sim: %d bodies%s, %d walls, %d ropes, %d angle rows; steps %lld..%lld (t = %.6g s) "
                "in %.3g s on %d thread%s -> %s\n",
                sum.bodies, kinds.c_str(), sum.walls, sum.ropes, sum.angles,
                static_cast<long long>(sum.first_step), static_cast<long long>(sum.first_step + sum.steps),
                sum.time_s, sum.wall_seconds, sum.threads, sum.threads == 1 ? "" : "s", output.c_str());
    std::printf("sim: %zu snapshots, %zu checkpoints, %lld iteration-cap hits, max overlap %.3g d, "
                "state hash %016llx\n",
                sum.snapshots, sum.checkpoints, static_cast<long long>(sum.iteration_cap_hits),
                sum.max_overlap_over_d, static_cast<unsigned long long>(sum.state_hash));
    if (sum.cycles_done > 0)
      std::printf("sim: %lld whole drive cycles%s\n", static_cast<long long>(sum.cycles_done),
                  sum.stopped_steady ? "; stopped early: the torque amplitude is steady (stop_change)" : "");
  }
}

int run_sim(SimCli& s, const Context& ctx) {
  s.job.scene = s.scene;
  s.job.output_dir = s.output;
  s.job.restart = s.restart;
  core::ProgressReporter drop("sim: fill drop steps", ctx.level), relax("sim: fill relaxation steps", ctx.level);
  const sim::FillProgress fill{[&](std::size_t k, std::size_t n) { drop.update(k, n); },
                               [&](std::size_t k, std::size_t n) {
                                 drop.finish();
                                 relax.update(k, n);
                               }};
  if (s.restart.empty() && pipeline::scene_has_protocol(s.job.scene)) {
    // The whole protocol: pre-shear, then every amplitude branch, each in its own folder.
    auto progress = std::make_unique<core::ProgressReporter>("sim: preshear steps", ctx.level);
    const auto stage = [&](const pipeline::SimProtocolStage& st) {
      progress->finish();
      print_summary(st.summary, (std::filesystem::path(s.output) / st.name).string(), ctx);
      progress = std::make_unique<core::ProgressReporter>("sim: branch steps", ctx.level);
    };
    const auto sum =
        pipeline::run_sim_protocol(s.job, ctx.header(),
                                   [&](std::size_t k, std::size_t n) {
                                     drop.finish();
                                     relax.finish();
                                     progress->update(k, n);
                                   },
                                   stage, fill);
    progress->finish();
    if (ctx.level != core::LogLevel::kQuiet)
      std::printf("sim: protocol done: pre-shear and %zu amplitude branches -> %s/protocol.csv\n",
                  sum.stages.size() - 1, s.output.c_str());
    return kExitOk;
  }
  core::ProgressReporter progress("sim: steps", ctx.level);
  const auto sum = pipeline::run_sim_job(
      s.job, ctx.header(),
      [&](std::size_t k, std::size_t n) {
        drop.finish();
        relax.finish();
        progress.update(k, n);
      },
      fill);
  progress.finish();
  print_summary(sum, s.output, ctx);
  return kExitOk;
}

}  // namespace

std::vector<Subcommand> add_sim(CLI::App& root, Context& ctx) {
  auto s = std::make_shared<SimCli>();
  CLI::App* c = root.add_subcommand(
      "sim", "Contact-dynamics simulation of a scene (TOML) -> snapshots (HDF5 + XDMF), "
             "checkpoints, diagnostics CSV; a scene with [protocol] runs pre-shear and every amplitude branch");
  c->add_option("scene", s->scene, "Scene .toml (keys: docs/sim.md)")
      ->required();
  c->add_option("-o,--output", s->output, "Run folder")->required();
  c->add_option("--restart", s->restart,
                "Continue from this checkpoint .h5 (the scene then gives duration and output cadence)");
  c->add_flag("--force", s->job.force, "Replace existing outputs");
  c->add_option("--phi0", s->job.branch_phi0_rad,
                "Amplitude branch from --restart: the vane turns phi0 sin(2 pi f (t - t_checkpoint)), rad; "
                "range: |phi0| <= 100");
  c->add_option("--f-hz", s->job.branch_f_Hz,
                "Frequency of the branch (default: the checkpoint's), Hz; range: 0 < f <= 1000");
  c->add_option("--cycles", s->job.branch_cycles,
                "Length of the branch in cycles (default 3; replaces duration_s); range: 0 < cycles <= 1e6");
  return {{c, [s, &ctx] { return run_sim(*s, ctx); }}};
}

}  // namespace shearzone::apps
