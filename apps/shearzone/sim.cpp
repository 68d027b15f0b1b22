// `shearzone sim`: a contact-dynamics scene (TOML) -> snapshots (HDF5 + XDMF),
// checkpoints and the diagnostics CSV in one folder. Flags map onto
// pipeline::SimJobOptions; the scene keys are in shearzone/pipeline/sim_job.hpp.
#include <cmath>
#include <cstdio>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include <filesystem>
#include <memory>
#include <string>

#include "shearzone/core/unset.hpp"
#include "shearzone/pipeline/sim_check_job.hpp"
#include "shearzone/pipeline/sim_job.hpp"
#include "shearzone/pipeline/sim_render_job.hpp"
#include "subcommands.hpp"

namespace shearzone::apps {
namespace {

struct SimCli {
  pipeline::SimJobOptions job;
  std::string scene, output, restart;
  bool preshear = false;
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

int run_sim(CLI::App& c, SimCli& s, const Context& ctx) {
  // (not ->required(): `sim render` and `sim check` take their own arguments)
  if (s.scene.empty()) throw CLI::RequiredError("scene is required: shearzone sim SCENE.toml -o RUN/");
  require_option(c, "output");
  s.job.scene = s.scene;
  s.job.output_dir = s.output;
  s.job.restart = s.restart;
  core::ProgressReporter drop("sim: fill drop steps", ctx.level), relax("sim: fill relaxation steps", ctx.level);
  const sim::FillProgress fill{[&](std::size_t k, std::size_t n) { drop.update(k, n); },
                               [&](std::size_t k, std::size_t n) {
                                 drop.finish();
                                 relax.update(k, n);
                               }};
  if (!s.preshear && s.restart.empty() && pipeline::scene_has_protocol(s.job.scene)) {
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
  // One run: the scene, a continuation or branch from --restart, or (--preshear) a
  // protocol's pre-shear alone, the folder the protocol writes as run/preshear.
  core::ProgressReporter progress(s.preshear ? "sim: preshear steps" : "sim: steps", ctx.level);
  const core::ProgressCallback on_step = [&](std::size_t k, std::size_t n) {
    drop.finish();
    relax.finish();
    progress.update(k, n);
  };
  const auto sum = s.preshear ? pipeline::run_sim_preshear(s.job, ctx.header(), on_step, fill)
                              : pipeline::run_sim_job(s.job, ctx.header(), on_step, fill);
  progress.finish();
  print_summary(sum, s.output, ctx);
  return kExitOk;
}

struct RenderCli {
  pipeline::SimRenderOptions job;
  std::string run, output;
  std::vector<int> size;
};

/// The small-bead note of `sim render` and `sim check` (subcommands.hpp).
void warn_bead_size(double bead_px) {
  if (bead_px < kSmallBeadPx)
    note_small_beads("sim render", "beads are", bead_px,
                     "with H.264, film at 15 px per bead or more (--size or --m-per-px)");
}

/// The camera and look options that `sim render` and `sim check` share.
void add_camera_options(CLI::App* c, pipeline::SimRenderOptions& j, std::vector<int>& size) {
  c->add_option("--codec", j.codec, "MP4 codec: mp4v or avc1 (H.264 where FFmpeg has it)")->capture_default_str();
  c->add_option("--projection", j.projection, "pinhole or orthographic")->capture_default_str();
  c->add_option("--size", size, "Image size W,H in px; range: 16..16384 each (even for mp4)")
      ->expected(2)
      ->delimiter(',');
  c->add_option("--m-per-px", j.m_per_px,
                "Scale on the bead surface, m per px (default: the rim fills 90 % of the shorter side); range: > 0");
  c->add_option("--height-m", j.height_m, "Pinhole above the bead surface, m; range: > 0")->capture_default_str();
  c->add_option("--noise", j.look.noise, "Sensor noise, fraction of full scale; range: 0..1")->capture_default_str();
  c->add_option("--blur-px", j.look.blur_px, "Gaussian blur sigma, px; range: 0..50")->capture_default_str();
  c->add_option("--jpeg-quality", j.look.jpeg_quality,
                "Compression artefacts: each frame through JPEG at this quality; range: 1..100, 0 none")
      ->capture_default_str();
  c->add_option("--seed", j.look.seed, "Seed of the noise and the beads' albedo scatter; range: 0..18446744073709551615")->capture_default_str();
  c->add_option("--first", j.first_frame, "First frame of frames.h5 drawn; range: >= 0")->capture_default_str();
  c->add_option("--last", j.last_frame, "Last frame drawn; range: > --first, or -1 (to the end)")->capture_default_str();
}

void apply_size(pipeline::SimRenderOptions& j, const std::vector<int>& size) {
  if (!size.empty()) {
    j.width_px = size[0];
    j.height_px = size[1];
  }
}

struct CheckCli {
  pipeline::SimCheckOptions job;
  std::string run, output;
  std::vector<int> size, windows, final_windows, passes{3}, spacings{1};
  std::vector<std::string> interpolations;
  std::vector<std::string> methods{"piv"};
  std::string estimator = "auto";
  std::string smoothing_fit = "auto";
  bool passes_given = false;
};

int run_check(CheckCli& s, const Context& ctx) {
  auto& j = s.job;
  j.run_dir = s.run;
  j.output_dir = s.output;
  apply_size(j.render, s.size);
  j.width.estimator = profile::estimator_from_name(s.estimator);
  if (!s.windows.empty()) j.piv.piv.windows_px = s.windows;
  j.piv.fit_predictor_to_texture = s.smoothing_fit == "auto";
  if (!j.piv.fit_predictor_to_texture) j.piv.piv.predictor_fit = piv::predictor_fit_from_name(s.smoothing_fit);
  // --passes shapes the --final-windows grid: checked always, and refused without it
  // (it was ignored there, out of range or not).
  for (const int p : s.passes)
    if (!(p >= 1 && p <= 6)) throw ConfigError(fmt::format("--passes {}: expected 1..6", p));
  if (s.passes_given && s.final_windows.empty())
    throw ConfigError("--passes: it sets the passes of the --final-windows grid; give --final-windows too "
                      "(or --windows for one window list)");
  // The grid: final windows x passes (halving down to the final window) x
  // interpolations x pair spacings; --windows alone is one window list.
  std::vector<std::vector<int>> grids;
  for (const int w : s.final_windows) {
    if (w != 8 && w != 16 && w != 32 && w != 64)
      throw ConfigError(fmt::format("--final-windows {}: expected 8, 16, 32 or 64 px", w));
    for (const int p : s.passes) {
      std::vector<int> g;
      for (int q = p - 1; q >= 0; --q) g.push_back(w << q);
      grids.push_back(std::move(g));
    }
  }
  // Windows given (--windows, --final-windows) are used as given; else sized to the texture.
  j.piv.size_windows_to_texture = grids.empty() && s.windows.empty();
  if (grids.empty()) grids.push_back(j.piv.piv.windows_px);
  std::vector<std::string> interps = s.interpolations;
  if (interps.empty()) interps.push_back("");
  for (const auto& m : s.methods) {
    if (pipeline::pair_method_from_name(m) == pipeline::PairMethod::kTrack) {
      for (const int k : s.spacings) j.settings.push_back({{}, k, "", pipeline::PairMethod::kTrack});
      continue;
    }
    for (const auto& g : grids)
      for (const auto& in : interps)
        for (const int k : s.spacings) j.settings.push_back({g, k, in});
  }
  core::ProgressReporter progress("sim check: stages", ctx.level);
  const auto rows =
      pipeline::run_sim_check(j, ctx.header(), [&](const std::string& st, std::size_t done, std::size_t total) {
        if (ctx.level == core::LogLevel::kVerbose) std::fprintf(stderr, "sim check: %s\n", st.c_str());
        progress.update(done, total);
      });
  progress.finish();
  if (ctx.level != core::LogLevel::kQuiet) {
    auto rc = [](const pipeline::WidthRow& r) {
      return r.label == "no_result" ? std::string("no result")
                                    : fmt::format("{} ({})", std::isfinite(r.rc_m) ? fmt::format("{:.4g} m", r.rc_m)
                                                                                   : std::string("-"),
                                                  profile::width_status_name(r.status));
    };
    for (const auto& r : rows)
      std::printf("sim check: %s %s: r_c video %s, camera truth %s, surface truth %s; PIV RMS error %.3g px over "
                  "%zu vectors, %.1f%% invalid; piv %.1f s\n",
                  r.branch.c_str(), r.setting.c_str(), rc(r.video).c_str(), rc(r.centres).c_str(),
                  rc(r.surface).c_str(), r.piv_rms_error_px, r.compared_vectors, 100.0 * r.invalid_fraction, r.piv_s);
    std::printf("sim check: %zu rows -> %s/closed_loop.csv\n", rows.size(), s.output.c_str());
    if (!rows.empty()) warn_bead_size(rows.front().bead_diameter_px);
  }
  return kExitOk;
}

int run_render(RenderCli& s, const Context& ctx) {
  s.job.run_dir = s.run;
  s.job.output_dir = s.output;
  apply_size(s.job, s.size);
  if (ctx.check_options) {  // the study's option check: no file read
    s.job.validate();
    return kExitOk;
  }
  core::ProgressReporter progress("sim render: frames", ctx.level);
  const auto sum = pipeline::run_sim_render(s.job, ctx.header(), progress.callback());
  progress.finish();
  if (ctx.level != core::LogLevel::kQuiet) {
    std::printf("sim render: %zu frames (%s, %dx%d px, %.6g m per px on the bead surface at z = %.4g m, bead "
                "%.3g px) in %.2f s -> %s\n",
                sum.frames, sum.camera.projection_name().c_str(), sum.camera.width_px, sum.camera.height_px,
                sum.camera.m_per_px, sum.surface_z_m, sum.bead_diameter_px, sum.seconds,
                s.output.c_str());
    std::printf("sim render: cup centre (%.2f, %.2f) px, cup radius %.2f px (rim %.2f px), vane radius %.2f px; "
                "`shearzone piv` takes them from %s/piv.toml\n",
                sum.image.centre_x_px, sum.image.centre_y_px, sum.image.cup_radius_px, sum.image.rim_radius_px,
                sum.image.vane_radius_px, s.output.c_str());
    warn_bead_size(sum.bead_diameter_px);
  }
  return kExitOk;
}

}  // namespace

std::vector<Subcommand> add_sim_render(CLI::App& sim, Context& ctx) {
  auto s = std::make_shared<RenderCli>();
  auto& j = s->job;
  CLI::App* c = sim.add_subcommand("render", "A run's frames (frames.h5) as the lab camera films them: MP4 or PNG "
                                             "frames, camera.json, piv.toml and the vane's angle log");
  c->add_option("run", s->run, "Run folder holding frames.h5 (a scene with [camera])")->required();
  c->add_option("-o,--output", s->output, "Output folder")->required();
  c->add_flag("--force", j.force, "Replace existing outputs");
  c->add_option("--format", j.format, "mp4 or png (a frame_NNNNNN.png sequence)")->capture_default_str();
  add_camera_options(c, j, s->size);
  std::vector<Subcommand> subs{{c, [s, &ctx] { return run_render(*s, ctx); }}};

  auto k = std::make_shared<CheckCli>();
  CLI::App* ck = sim.add_subcommand(
      "check", "Closed loop: film a run's branches, run piv -> profile -> width on the video and compare with the "
               "simulator's truth -> closed_loop.csv");
  ck->add_option("run", k->run, "Run folder with frames.h5, or a protocol run (its branch folders)")->required();
  ck->add_option("-o,--output", k->output, "Output folder")->required();
  ck->add_flag("--force", k->job.force, "Replace existing outputs");
  add_camera_options(ck, k->job.render, k->size);
  ck->add_option("--windows", k->windows, "PIV window sizes per pass, px (default: piv's 64,32,16); range: powers of two, 8..256")->delimiter(',');
  ck->add_option("--final-windows", k->final_windows,
                 "Grid of PIV settings: final window W, px, with --passes P: windows 2^(P-1) W, ..., 2W, W; range: "
                 "8, 16, 32 or 64")
      ->delimiter(',');
  ck->add_option("--passes", k->passes, "Grid: passes per final window; range: 1..6 (windows up to 256 px)")
      ->delimiter(',')
      ->capture_default_str();
  ck->add_option("--interpolations", k->interpolations,
                 "Grid: image deformation interpolations (bilinear, bicubic, bspline, bspline5; default: piv's)")
      ->delimiter(',');
  ck->add_option("--smoothing-fit", k->smoothing_fit,
                 "PIV's predictor smoothing in every setting: auto, gaussian or quadratic (as piv --smoothing-fit)")
      ->check(CLI::IsMember({"auto", "gaussian", "quadratic"}))
      ->capture_default_str();
  ck->add_option("--methods", k->methods,
                 "How the video's pairs are measured: piv (the window grid above), track (each bead tracked, one "
                 "row per spacing; docs/track.md), or both: piv,track")
      ->delimiter(',')
      ->check(CLI::IsMember({"piv", "track"}))
      ->capture_default_str();
  ck->add_option("--spacings", k->spacings, "Grid of pair spacings k: pairs (i, i+k); range: 1..1000")
      ->delimiter(',')
      ->capture_default_str();
  ck->add_option("--vc", k->job.width.v_c_m_per_s, "Threshold velocity v_c of every width, m/s; range: > 0")
      ->capture_default_str();
  ck->add_option("--estimator", k->estimator,
                 "Width estimator of every width: mean-abs (the paper's mean |v|), lockin (the drive-locked part) or "
                 "auto (width's default)")
      ->capture_default_str();
  ck->add_option("--bootstrap", k->job.width.bootstrap, "Bootstrap resamples of every width; range: 0..1000000")
      ->capture_default_str();
  ck->add_option("--truth-spacing-px", k->job.truth_spacing_px, "Grid step of the camera's truth field, px; range: 1..1024")
      ->capture_default_str();
  subs.push_back({ck, [k, ck, &ctx] {
                    k->passes_given = ck->count("--passes") > 0;
                    return run_check(*k, ctx);
                  }});
  return subs;
}

std::vector<Subcommand> add_sim(CLI::App& root, Context& ctx) {
  auto s = std::make_shared<SimCli>();
  CLI::App* c = root.add_subcommand(
      "sim", "Contact-dynamics simulation of a scene (TOML) -> snapshots (HDF5 + XDMF), "
             "checkpoints, diagnostics CSV; a scene with [protocol] runs pre-shear and every amplitude branch");
  c->add_option("scene", s->scene, "Scene .toml (keys: docs/sim.md)");
  c->add_option("-o,--output", s->output, "Run folder");
  c->add_option("--restart", s->restart,
                "Continue from this checkpoint .h5 (the scene then gives duration and output cadence)");
  c->add_flag("--force", s->job.force, "Replace existing outputs");
  c->add_flag("--preshear", s->preshear,
              "A [protocol] scene: run only its fill and pre-shear into -o (what the protocol writes to "
              "RUN/preshear; branches then restart from its checkpoint.h5)");
  c->add_option("--phi0", s->job.branch_phi0_rad,
                "Amplitude branch from --restart: the vane turns phi0 sin(2 pi f (t - t_checkpoint)), rad; "
                "range: |phi0| <= 100");
  c->add_option("--f-hz", s->job.branch_f_Hz,
                "Frequency of the branch (default: the checkpoint's), Hz; range: 0 < f <= 1000");
  c->add_option("--cycles", s->job.branch_cycles,
                "Length of the branch in cycles (default 3; replaces duration_s); range: 0 < cycles <= 1e6");
  std::vector<Subcommand> subs = add_sim_render(*c, ctx);
  subs.push_back({c, [c, s, &ctx] { return run_sim(*c, *s, ctx); }});  // after its children: they parse it too
  return subs;
}

}  // namespace shearzone::apps
