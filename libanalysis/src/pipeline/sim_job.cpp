// `shearzone sim`: see shearzone/pipeline/sim_job.hpp.
#include "shearzone/pipeline/sim_job.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/core/hash.hpp"
#include "shearzone/io/atomic_output.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/io/field_file.hpp"
#include "shearzone/sim/frames_file.hpp"
#include "shearzone/sim/scene.hpp"
#include "shearzone/sim/sim_io.hpp"
#include "shearzone/sim/surface.hpp"
#include "shearzone/sim/world.hpp"

namespace shearzone::pipeline {

SimJobSummary run_sim_job(const SimJobOptions& o, const core::Metadata& header,
                          const core::ProgressCallback& progress, const sim::FillProgress& fill_progress) {
  SimJobSummary sum;
  std::vector<std::int64_t> chain_ids;
  std::optional<sim::World> built;
  // Every file this run will write, refused before the fill (minutes for a large cup)
  // rather than after it: the scene read first without placing anything tells which.
  const auto refuse_existing = [&](const sim::LoadedScene& sc) {
    std::vector<std::string> names{"snapshots.h5", "snapshots.xdmf", "diagnostics.csv", "checkpoint.h5"};
    if (sc.vane) {
      names.emplace_back("torque.csv");
      if (!std::isnan(o.branch_phi0_rad) || sc.vane_f_Hz > 0) names.emplace_back("cycles.csv");
    }
    if (sc.camera) {
      names.emplace_back("surface.h5");
      if (sc.camera->frames && o.camera_frames) names.emplace_back("frames.h5");
    }
    for (const std::string& name : names) io::check_output_allowed(o.output_dir / name, o.force);
  };
  if (o.restart.empty()) refuse_existing(sim::load_scene(o.scene, true));
  sim::LoadedScene scene = sim::load_scene(o.scene, !o.restart.empty(), fill_progress);
  if (!o.restart.empty()) refuse_existing(scene);
  const sim::SceneCadence cad = scene.cadence;
  if (o.restart.empty()) {
    built.emplace(std::move(*scene.world));
    chain_ids = std::move(scene.chain_ids);
    sum.fill = scene.fill;
  } else {
    // The scene's sections were checked; the world comes from the checkpoint.
    sim::WorldState state = sim::read_checkpoint(o.restart);
    sim::check_checkpoint_matches(scene, state, o.scene, o.restart);
    built.emplace(sim::World::from_state(std::move(state)));
    chain_ids = sim::chain_ids_from_ropes(built->state());
  }
  sim::World& w = *built;
  // The vane's torque as the whole cup's: k blades in a periodic sector of 1/k.
  const double torque_scale = w.options().sectors != 0 ? w.options().sectors : 1.0;
  auto whole_torque = [&] { return torque_scale * w.rotor_torque(0); };
  const bool branch = !std::isnan(o.branch_phi0_rad);
  if (branch) {
    if (o.restart.empty())
      throw ConfigError("--phi0 starts an amplitude branch from a checkpoint: give --restart (the pre-sheared state)");
    if (w.rotor_count() == 0)
      throw InputError(fmt::format("{}: the checkpoint has no vane: an amplitude branch needs one", o.restart.string()));
    const double f = std::isnan(o.branch_f_Hz) ? w.rotor(0).f_Hz : o.branch_f_Hz;
    sim::validate_branch(w.options().sectors, w.options().time_step, w.time(), o.branch_phi0_rad, f,
                         std::isnan(o.branch_cycles) ? 3.0 : o.branch_cycles);
    w.set_rotor_drive(0, o.branch_phi0_rad, f, 0.0, w.time());
  } else if (!std::isnan(o.branch_f_Hz) || !std::isnan(o.branch_cycles)) {
    throw ConfigError("--f-hz and --cycles belong to an amplitude branch: give --phi0 (and --restart)");
  }

  sum.first_step = w.steps_done();
  sum.bodies = w.body_count();
  for (int k = 0; k < w.body_count(); ++k) {
    if (w.kind(k) == sim::BodyKind::kFixed) ++sum.fixed_bodies;
    if (w.kind(k) == sim::BodyKind::kKinematic) ++sum.kinematic_bodies;
  }
  sum.walls = static_cast<int>(w.walls().size());
  sum.ropes = w.rope_count();
  sum.angles = w.angle_count();
  sum.threads = w.options().threads;
  const double h = w.options().time_step;
  // The number of steps must be a count this run can reach (and llround can hold).
  constexpr double kMaxSteps = sim::kMaxRunSteps;
  const double branch_end_s =
      branch ? w.time() + (std::isnan(o.branch_cycles) ? 3.0 : o.branch_cycles) / w.rotor(0).f_Hz : 0.0;
  const double steps = (branch ? branch_end_s : cad.duration_s) / h;
  if (!branch && !(steps <= kMaxSteps))  // a branch's length: sim::validate_branch above
    throw ConfigError(fmt::format("{}: sim.duration_s = {} s over sim.time_step_s = {} s is {:.3g} steps; "
                                  "expected at most {:.0e} (a longer time step or a shorter run)",
                                  o.scene.string(), io::format_number(cad.duration_s),
                                  io::format_number(h), steps, kMaxSteps));
  const auto end_step = static_cast<std::int64_t>(std::llround(steps));
  const std::int64_t todo = std::max<std::int64_t>(0, end_step - w.steps_done());

  core::Metadata meta = header;
  meta.emplace_back("scene", o.scene.string());
  if (!o.restart.empty()) meta.emplace_back("restart", o.restart.string());
  if (branch) {
    const sim::Rotor& r = w.rotor(0);
    meta.emplace_back("branch", fmt::format("amplitude branch: phi = {} sin(2 pi {} (t - {})) for {} cycles from the "
                                            "checkpoint",
                                            io::format_number(r.phi0), io::format_number(r.f_Hz),
                                            io::format_number(r.t_start),
                                            io::format_number(std::isnan(o.branch_cycles) ? 3.0 : o.branch_cycles)));
  }
  // One id for every file of this run (frames.h5 and surface.h5 carry it: sim check
  // refuses a pair from two runs): the starting state, the drive and the step range,
  // hashed (core::Fnv1a), so a rerun writes the same bytes.
  {
    core::Fnv1a id;
    id.u(w.state_hash());
    id.u(static_cast<std::uint64_t>(end_step));
    if (w.rotor_count() > 0) {
      const sim::Rotor& r = w.rotor(0);
      for (const double v : {r.phi0, r.f_Hz, r.phase, r.t_start}) id.d(v);
    }
    meta.emplace_back("run_id", fmt::format("{:016x}", id.h));
  }
  meta.emplace_back("time_step_s", io::format_number(h));
  meta.emplace_back("threads", std::to_string(w.options().threads));
  meta.emplace_back("freeze_sweeps", std::to_string(w.options().freeze_sweeps));
  meta.emplace_back("sweep_order", w.options().alternate_sweeps ? "alternate" : "forward");
  meta.emplace_back("anderson_depth", std::to_string(w.options().anderson_depth));
  if (const int k = w.options().sectors; k != 0)
    meta.emplace_back("sector", fmt::format("periodic 1/{} of the cup (cylinder.sectors = {}, azimuth from {} rad): "
                                            "the snapshots hold that wedge; torques are the whole cup's, {} x the "
                                            "wedge's blade",
                                            k, k, io::format_number(w.options().sector_start), k));
  meta.emplace_back("bodies", std::to_string(w.body_count()));
  if (sum.kinematic_bodies > 0) meta.emplace_back("kinematic_bodies", std::to_string(sum.kinematic_bodies));
  if (sum.fill.settled) {
    meta.emplace_back("fill_settle_steps", std::to_string(sum.fill.settle_steps));
    meta.emplace_back("fill_settle_cap_hits", std::to_string(sum.fill.settle_cap_hits));
    meta.emplace_back("fill_drop_end", sum.fill.settle_plateau
                                           ? "plateau (the drop's kinetic energy stopped falling)"
                                           : "settle_kinetic_energy reached");
    meta.emplace_back("fill_wall_s", fmt::format("{:.3f}", sum.fill.seconds));
    meta.emplace_back("fill_relax_steps", std::to_string(sum.fill.relax_steps));
    meta.emplace_back("fill_relaxed", sum.fill.relaxed ? "true" : "false");
    meta.emplace_back("fill_kinetic_energy_per_bead_over_mgd", io::format_number(sum.fill.kinetic_energy));
    meta.emplace_back("fill_note", "step 0 is the relaxed packing (the drop and relaxation steps are not counted)");
  }

  io::AtomicOutputSet out(o.output_dir, o.force);
  io::AtomicOutput& snap_file = out.add("snapshots.h5");
  io::AtomicOutput& xdmf_file = out.add("snapshots.xdmf");
  io::AtomicOutput& diag_file = out.add("diagnostics.csv");
  out.check("checkpoint.h5");
  io::AtomicOutput* ckpt_file = nullptr;

  // The vane's torque log (rotor 0): what a rheometer records, in the generic log layout
  // that `shearzone laos` reads with no options.
  io::AtomicOutput* torque_file = w.rotor_count() > 0 ? &out.add("torque.csv") : nullptr;
  std::optional<io::CsvWriter> torque;
  if (torque_file) {
    const sim::Rotor& r = w.rotor(0);
    core::Metadata tm = meta;
    tm.emplace_back("N", std::to_string(scene.beads_per_chain));
    tm.emplace_back("phi0_rad", io::format_number(r.phi0));
    tm.emplace_back("f_Hz", io::format_number(r.f_Hz));
    tm.emplace_back("angle_rad", "vane deflection phi(t) = phi0 sin(2 pi f (t - t_start) + phase), > 0 "
                                 "counter-clockwise seen from above (+z)");
    tm.emplace_back("torque_N_m", "motor torque about the vane axis, > 0 drives towards +phi (as a rheometer "
                                  "reports it), from the contact impulses on the vane beads, averaged over the "
                                  "steps since the previous row");
    tm.emplace_back("sampling", scene.torque_every_rad > 0
                                    ? fmt::format("a row each time phi has changed by {} rad since the previous row "
                                                  "(time and angle at the row's step)",
                                                  io::format_number(scene.torque_every_rad))
                                    : std::string("every step"));
    torque.emplace(torque_file->stream(), tm, std::vector<std::string>{"time_s", "angle_rad", "torque_N_m"});
  }
  double torque_impulse = 0.0, torque_time = 0.0, phi_last = w.rotor_count() > 0 ? w.rotor_angle(0) : 0.0;

  // The surface field (a [camera]): one pair per frame interval, frames at the steps
  // nearest k / fps from the run's start.
  io::AtomicOutput* surface_file = scene.camera ? &out.add("surface.h5") : nullptr;
  std::optional<io::FieldFileWriter> surface;
  std::optional<sim::SurfaceCamera> camera;
  std::int64_t frame = 0, next_frame_step = w.steps_done();
  const double frame_s = scene.camera ? 1.0 / scene.camera->fps : 0.0;
  const double t_first = w.time();
  double t_frame = t_first;
  if (scene.camera) {
    surface.emplace(surface_file->temp_path());
    camera.emplace(scene.camera->options);
    camera->record(w);
    next_frame_step = w.steps_done() + std::llround(frame_s / h);
  }
  // The bodies at every camera frame (frame k of surface.h5's pairs is record k), with
  // the scene a renderer needs (pipeline/sim_render_job.hpp, synth/cup_view.hpp).
  std::optional<sim::SnapshotWriter> frames;
  if (scene.camera && scene.camera->frames && o.camera_frames) {
    core::Metadata fm = meta;
    sim::add_frames_metadata(fm, *scene.camera, scene.beads_per_chain, w);
    frames.emplace(out.add("frames.h5").temp_path(), w, fm, chain_ids);
    frames->append(w);
  }

  // Per drive cycle of the vane (f > 0): the torque's fundamental amplitude and the
  // solver's work, and the early stop of a pre-shear (vane.stop_change).
  const bool cycling = w.rotor_count() > 0 && w.rotor(0).f_Hz > 0;
  io::AtomicOutput* cycles_file = cycling ? &out.add("cycles.csv") : nullptr;
  std::optional<io::CsvWriter> cycles;
  if (cycling) {
    core::Metadata cm = meta;
    cm.emplace_back("cycle", "floor(f (t - t_start)) of the vane's drive; a row per whole cycle of this run");
    cm.emplace_back("torque_amplitude_N_m", "amplitude of the fundamental of the motor torque over the cycle "
                                            "(per-step torques against cos and sin of 2 pi f t)");
    cm.emplace_back("stop_change", io::format_number(scene.stop_change));
    cycles.emplace(cycles_file->stream(), cm,
                   std::vector<std::string>{"cycle", "torque_amplitude_N_m", "mean_sweeps_per_step", "cap_hits",
                                            "max_overlap_over_d", "wall_s"});
  }
  struct CycleSums {
    double c = 0, s = 0, sweeps = 0, overlap = 0;
    std::int64_t steps = 0, caps = 0;
  } cyc;
  auto cycle_of = [&](double t) {
    const sim::Rotor& r = w.rotor(0);
    return static_cast<std::int64_t>(std::floor(r.f_Hz * (t - r.t_start) + 1e-9));
  };
  std::int64_t current_cycle = cycling ? cycle_of(w.time()) : 0;
  std::vector<double>& amplitudes = sum.torque_amplitudes;  // per whole cycle
  auto cycle_wall = std::chrono::steady_clock::now();

  sim::SnapshotWriter snaps(snap_file.temp_path(), w, meta, chain_ids);
  sim::DiagnosticsCsv diag(diag_file.stream(), meta);
  auto checkpoint = [&] {
    if (ckpt_file == nullptr) ckpt_file = &out.add("checkpoint.h5");
    sim::write_checkpoint(ckpt_file->temp_path(), w, meta);
    ++sum.checkpoints;
  };
  auto finish_surface = [&] {
    if (!surface) return;
    if (!surface->started()) {  // no frame interval in the run: an empty field file is refused
      throw NoResultError(fmt::format("{}: the run holds no frame interval of the camera ({} s): run longer than "
                                      "1/fps or drop [camera]",
                                      o.scene.string(), io::format_number(frame_s)));
    }
    const sim::SurfaceCameraOptions& co = scene.camera->options;
    surface->set_attribute("fps", scene.camera->fps);
    surface->set_attribute("m_per_px", co.m_per_px);
    surface->set_attribute("centre_x_px", co.centre_x_px);
    surface->set_attribute("centre_y_px", co.centre_y_px);
    surface->set_attribute("cup_radius_px", co.cup_radius_m / co.m_per_px);
    surface->set_attribute("vane_radius_px", co.vane_radius_m / co.m_per_px);
    surface->set_attribute("N", static_cast<double>(scene.beads_per_chain));
    if (w.rotor_count() > 0) {
      const sim::Rotor& r = w.rotor(0);
      surface->set_attribute("f_Hz", r.f_Hz);
      surface->set_attribute("phi0_rad", r.phi0);
      // phi = phi0 sin(2 pi f (t - t_start) + phase) = phi0 sin(2 pi f t + vane_phase_rad)
      surface->set_attribute("vane_phase_rad", r.phase - 2.0 * std::numbers::pi * r.f_Hz * r.t_start);
    }
    surface->set_attribute("source", "shearzone sim: virtual top camera (exact surface motion)");
    surface->set_attribute("run_id", core::metadata_value(meta, "run_id"));
    // No measurement noise (float32 rounding only: 6e-8 relative): profile takes the
    // beads' radial motion as motion, not as the noise floor.
    surface->set_attribute("noise_sigma_px", 0.0);
    std::string conv;
    for (const auto& [k, v] : meta) conv += k + ": " + v + "\n";
    surface->set_attribute("options", conv);
    surface->set_attribute("surface", "each node sees the top-most mobile bead whose horizontal disc contains it; "
                                      "u_px, v_px: displacement of that material point from frame a to frame b "
                                      "(x right = +X, y down = -Y, seen from above); masked: vane disc and outside "
                                      "the cup; invalid: no bead");
    surface->close();
  };
  auto finish_files = [&] {
    finish_surface();
    if (frames) frames->close();
    snaps.close();
    sim::write_snapshot_xdmf(xdmf_file.stream(), "snapshots.h5", snaps.body_count(), snaps.times());
    sum.snapshots = snaps.snapshot_count();
  };

  const auto t0 = std::chrono::steady_clock::now();
  const std::int64_t cap0 = w.iteration_cap_hits();
  if (cad.snapshot_every > 0 || todo == 0) snaps.append(w);
  std::int64_t last_snapshot = w.steps_done();
  try {
    for (std::int64_t k = 1; k <= todo; ++k) {
      const sim::StepDiagnostics d = w.step();
      sum.max_overlap_over_d = std::max(sum.max_overlap_over_d, d.max_overlap);
      if (d.step % cad.diagnostics_every == 0 || k == todo) diag.row(d, w.time());
      if (camera && w.steps_done() == next_frame_step) {
        const core::VectorField f = camera->pair(w);
        surface->append(f, frame, frame + 1, t_frame, w.time() - t_frame);
        if (frames) frames->append(w);
        ++frame;
        t_frame = w.time();
        next_frame_step = sum.first_step + std::llround((t_first + static_cast<double>(frame + 1) * frame_s) / h) -
                          std::llround(t_first / h);
      }
      if (cycling) {
        const sim::Rotor& r = w.rotor(0);
        const double t_mid = w.time() - 0.5 * h;  // the step's torque acts over it
        const double a = 2.0 * std::numbers::pi * r.f_Hz * (t_mid - r.t_start);
        cyc.c += whole_torque() * std::cos(a);
        cyc.s += whole_torque() * std::sin(a);
        cyc.sweeps += d.iterations;
        cyc.caps += d.hit_iteration_cap ? 1 : 0;
        cyc.overlap = std::max(cyc.overlap, d.max_overlap);
        ++cyc.steps;
        const std::int64_t now_cycle = cycle_of(w.time());
        if (now_cycle != current_cycle) {  // a whole cycle has ended with this step
          const double n = static_cast<double>(cyc.steps);
          const double amp = 2.0 / n * std::hypot(cyc.c, cyc.s);
          const auto now = std::chrono::steady_clock::now();
          cycles->row(std::vector<std::string>{
              std::to_string(current_cycle), io::format_number(amp), io::format_number(cyc.sweeps / n),
              std::to_string(cyc.caps), io::format_number(cyc.overlap),
              fmt::format("{:.3f}", std::chrono::duration<double>(now - cycle_wall).count())});
          cycle_wall = now;
          amplitudes.push_back(amp);
          ++sum.cycles_done;
          cyc = CycleSums{};
          current_cycle = now_cycle;
          // Steady: three consecutive changes of the amplitude below stop_change.
          if (scene.stop_change > 0 && amplitudes.size() >= 4) {
            bool steady = true;
            for (std::size_t q = amplitudes.size() - 3; q < amplitudes.size(); ++q)
              steady = steady && std::abs(amplitudes[q] - amplitudes[q - 1]) <= scene.stop_change * amplitudes[q];
            if (steady) sum.stopped_steady = true;
          }
        }
      }
      if (torque) {
        torque_impulse += whole_torque() * h;
        torque_time += h;
        const double phi = w.rotor_angle(0);
        if (scene.torque_every_rad == 0 || std::abs(phi - phi_last) >= scene.torque_every_rad || k == todo ||
            sum.stopped_steady) {
          torque->row(std::vector<double>{w.time(), phi, torque_impulse / torque_time});
          torque_impulse = torque_time = 0.0;
          phi_last = phi;
        }
      }
      if (cad.snapshot_every > 0 && d.step % cad.snapshot_every == 0) {
        snaps.append(w);
        last_snapshot = d.step;
      }
      if (cad.checkpoint_every > 0 && d.step % cad.checkpoint_every == 0 && k != todo) checkpoint();
      if (progress) progress(static_cast<std::size_t>(k), static_cast<std::size_t>(todo));
      if (sum.stopped_steady) break;
    }
  } catch (const NoResultError&) {
    // The failing step's state is not written; what was written up to it is whole.
    sum.steps = w.steps_done() - sum.first_step;
    // A surface field needs one frame interval; a run that diverges before it commits nothing.
    if (surface && !surface->started()) throw;
    finish_files();
    out.commit_all();
    throw;
  }
  if (last_snapshot != w.steps_done()) snaps.append(w);
  checkpoint();
  finish_files();
  out.commit_all();
  sum.steps = w.steps_done() - sum.first_step;
  sum.time_s = w.time();
  sum.state_hash = w.state_hash();
  sum.iteration_cap_hits = w.iteration_cap_hits() - cap0;
  sum.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return sum;
}

bool scene_has_protocol(const std::filesystem::path& scene) {
  return sim::load_scene(scene, true).protocol.has_value();
}

namespace {

/// The protocol's pre-shear: the scene's fill and drive into its own folder, without
/// frames.h5 (its minutes of frames are not a measurement).
SimJobSummary run_preshear_stage(SimJobOptions pre, const sim::SceneProtocol& p, const core::Metadata& header,
                                 const core::ProgressCallback& progress, const sim::FillProgress& fill_progress) {
  pre.camera_frames = false;
  core::Metadata h = header;
  h.emplace_back("protocol_stage",
                 fmt::format("pre-shear: phi = {} sin(2 pi {} t) for {} s (stop_change {})",
                             io::format_number(p.preshear_phi0_rad), io::format_number(p.preshear_f_Hz),
                             io::format_number(p.preshear_s), io::format_number(p.stop_change)));
  return run_sim_job(pre, h, progress, fill_progress);
}

}  // namespace

SimJobSummary run_sim_preshear(const SimJobOptions& o, const core::Metadata& header,
                               const core::ProgressCallback& progress, const sim::FillProgress& fill_progress) {
  if (!o.restart.empty() || !std::isnan(o.branch_phi0_rad) || !std::isnan(o.branch_f_Hz) ||
      !std::isnan(o.branch_cycles))
    throw ConfigError("--preshear starts from the scene's fill: it takes no --restart, --phi0, --f-hz or --cycles");
  const sim::LoadedScene checked = sim::load_scene(o.scene, true);
  if (!checked.protocol)
    throw ConfigError(fmt::format("{}: --preshear needs a [protocol] section (docs/sim.md)", o.scene.string()));
  return run_preshear_stage(o, *checked.protocol, header, progress, fill_progress);
}

SimProtocolSummary run_sim_protocol(const SimJobOptions& o, const core::Metadata& header,
                                    const core::ProgressCallback& progress,
                                    const std::function<void(const SimProtocolStage&)>& on_stage,
                                    const sim::FillProgress& fill_progress) {
  if (!o.restart.empty() || !std::isnan(o.branch_phi0_rad) || !std::isnan(o.branch_f_Hz) ||
      !std::isnan(o.branch_cycles))
    throw ConfigError("the whole protocol starts from the scene: --restart, --phi0, --f-hz and --cycles run one "
                      "branch of it");
  const sim::LoadedScene checked = sim::load_scene(o.scene, true);
  if (!checked.protocol)
    throw ConfigError(fmt::format("{}: no [protocol] section (docs/sim.md)", o.scene.string()));
  const sim::SceneProtocol& p = *checked.protocol;
  namespace fs = std::filesystem;
  // Every folder is checked before the first step: hours of pre-shear must not end in a
  // refused branch folder.
  std::vector<std::string> names{"preshear"};
  for (const double a : p.phi0_rad) names.push_back(sim::SceneProtocol::branch_folder(a));
  if (!o.force) {
    for (const std::string& n : names)
      if (fs::exists(o.output_dir / n))
        throw ConfigError(fmt::format("{} exists: give --force to replace it", (o.output_dir / n).string()));
    if (fs::exists(o.output_dir / "protocol.csv"))
      throw ConfigError(fmt::format("{} exists: give --force to replace it",
                                    (o.output_dir / "protocol.csv").string()));
  }

  SimProtocolSummary out;
  out.checkpoint = o.output_dir / "preshear" / "checkpoint.h5";
  {
    SimJobOptions pre = o;
    pre.output_dir = o.output_dir / "preshear";
    SimProtocolStage st{"preshear", p.preshear_phi0_rad, p.preshear_f_Hz,
                        run_preshear_stage(pre, p, header, progress, fill_progress)};
    if (on_stage) on_stage(st);
    out.stages.push_back(std::move(st));
  }
  for (std::size_t k = 0; k < p.phi0_rad.size(); ++k) {
    SimJobOptions br = o;
    br.output_dir = o.output_dir / names[k + 1];
    br.restart = out.checkpoint;
    br.branch_phi0_rad = p.phi0_rad[k];
    br.branch_f_Hz = p.f_Hz;
    br.branch_cycles = p.cycles;
    core::Metadata h = header;
    h.emplace_back("protocol_stage", fmt::format("amplitude branch {} of {}", k + 1, p.phi0_rad.size()));
    SimProtocolStage st{names[k + 1], p.phi0_rad[k], p.f_Hz, run_sim_job(br, h, progress)};
    if (on_stage) on_stage(st);
    out.stages.push_back(std::move(st));
  }

  io::AtomicOutputSet set(o.output_dir, o.force);
  core::Metadata m = header;
  m.emplace_back("scene", o.scene.string());
  m.emplace_back("stage", "preshear (from the settled fill), then one amplitude branch per folder, each restarted "
                          "from preshear/checkpoint.h5");
  m.emplace_back("torque_amplitude_mean_N_m", "mean over the stage's whole cycles of the fundamental amplitude "
                                              "of the motor torque (cycles.csv)");
  io::CsvWriter csv(set.add("protocol.csv").stream(), m,
                    std::vector<std::string>{"stage", "phi0_rad", "f_Hz", "cycles", "steps", "end_time_s",
                                             "torque_amplitude_mean_N_m", "torque_amplitude_last_N_m",
                                             "iteration_cap_hits", "max_overlap_over_d", "wall_s", "state_hash"});
  for (const SimProtocolStage& st : out.stages) {
    const SimJobSummary& s = st.summary;
    double mean = 0.0;
    for (const double a : s.torque_amplitudes) mean += a;
    const bool has = !s.torque_amplitudes.empty();
    if (has) mean /= static_cast<double>(s.torque_amplitudes.size());
    csv.row(std::vector<std::string>{
        st.name, io::format_number(st.phi0_rad), io::format_number(st.f_Hz), std::to_string(s.cycles_done),
        std::to_string(s.steps), io::format_number(s.time_s), has ? io::format_number(mean) : "",
        has ? io::format_number(s.torque_amplitudes.back()) : "", std::to_string(s.iteration_cap_hits),
        io::format_number(s.max_overlap_over_d), fmt::format("{:.3f}", s.wall_seconds),
        fmt::format("{:016x}", s.state_hash)});
  }
  set.commit_all();
  return out;
}

}  // namespace shearzone::pipeline
