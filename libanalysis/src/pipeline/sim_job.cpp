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

namespace {

/// Every file a run of `sc` writes, refused (without --force) before the fill (minutes
/// for a large cup) rather than after it.
void refuse_existing(const SimJobOptions& o, const sim::LoadedScene& sc) {
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
}

/// The scene and its world: built and filled, or restarted from a checkpoint.
struct RunWorld {
  sim::LoadedScene scene;
  std::optional<sim::World> world;
  std::vector<std::int64_t> chain_ids;
};
RunWorld open_world(const SimJobOptions& o, const sim::FillProgress& fill_progress, SimJobSummary& sum) {
  // The scene read first without placing anything tells which files the run writes.
  if (o.restart.empty()) refuse_existing(o, sim::load_scene(o.scene, true));
  RunWorld r{sim::load_scene(o.scene, !o.restart.empty(), fill_progress), std::nullopt, {}};
  if (!o.restart.empty()) refuse_existing(o, r.scene);
  if (o.restart.empty()) {
    r.world.emplace(std::move(*r.scene.world));
    r.chain_ids = std::move(r.scene.chain_ids);
    sum.fill = r.scene.fill;
  } else {
    // The scene's sections were checked; the world comes from the checkpoint.
    sim::WorldState state = sim::read_checkpoint(o.restart);
    sim::check_checkpoint_matches(r.scene, state, o.scene, o.restart);
    r.world.emplace(sim::World::from_state(std::move(state)));
    r.chain_ids = sim::chain_ids_from_ropes(r.world->state());
  }
  return r;
}

/// An amplitude branch (--phi0): the vane's new drive from the checkpoint's time.
bool start_branch(const SimJobOptions& o, sim::World& w) {
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
  return branch;
}

void count_bodies(const sim::World& w, SimJobSummary& sum) {
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
}

/// The step at which the run ends: the scene's duration, or the branch's cycles.
std::int64_t end_step(const SimJobOptions& o, const sim::World& w, const sim::SceneCadence& cad, bool branch) {
  const double h = w.options().time_step;
  // The number of steps must be a count this run can reach (and llround can hold).
  constexpr double kMaxSteps = sim::kMaxRunSteps;
  const double branch_end_s =
      branch ? w.time() + (std::isnan(o.branch_cycles) ? 3.0 : o.branch_cycles) / w.rotor(0).f_Hz : 0.0;
  const double steps = (branch ? branch_end_s : cad.duration_s) / h;
  if (!branch && !(steps <= kMaxSteps))  // a branch's length: sim::validate_branch
    throw ConfigError(fmt::format("{}: sim.duration_s = {} s over sim.time_step_s = {} s is {:.3g} steps; "
                                  "expected at most {:.0e} (a longer time step or a shorter run)",
                                  o.scene.string(), io::format_number(cad.duration_s),
                                  io::format_number(h), steps, kMaxSteps));
  return static_cast<std::int64_t>(std::llround(steps));
}

/// The header every file of the run carries.
core::Metadata run_metadata(const SimJobOptions& o, const core::Metadata& header, const sim::World& w,
                            std::int64_t last_step, bool branch, const SimJobSummary& sum) {
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
    id.u(static_cast<std::uint64_t>(last_step));
    if (w.rotor_count() > 0) {
      const sim::Rotor& r = w.rotor(0);
      for (const double v : {r.phi0, r.f_Hz, r.phase, r.t_start}) id.d(v);
    }
    meta.emplace_back("run_id", fmt::format("{:016x}", id.h));
  }
  meta.emplace_back("time_step_s", io::format_number(w.options().time_step));
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
  return meta;
}

/// The vane's torque as the whole cup's: k blades in a periodic sector of 1/k.
double whole_torque(const sim::World& w) {
  return (w.options().sectors != 0 ? w.options().sectors : 1.0) * w.rotor_torque(0);
}

/// The vane's torque log (rotor 0): what a rheometer records, in the generic log layout
/// that `shearzone laos` reads with no options; a row per torque_every_rad of the angle.
class TorqueLog {
 public:
  TorqueLog(std::ostream& out, core::Metadata tm, const sim::LoadedScene& scene, const sim::World& w)
      : every_rad_(scene.torque_every_rad), phi_last_(w.rotor_angle(0)) {
    const sim::Rotor& r = w.rotor(0);
    tm.emplace_back("N", std::to_string(scene.beads_per_chain));
    tm.emplace_back("phi0_rad", io::format_number(r.phi0));
    tm.emplace_back("f_Hz", io::format_number(r.f_Hz));
    tm.emplace_back("angle_rad", "vane deflection phi(t) = phi0 sin(2 pi f (t - t_start) + phase), > 0 "
                                 "counter-clockwise seen from above (+z)");
    tm.emplace_back("torque_N_m", "motor torque about the vane axis, > 0 drives towards +phi (as a rheometer "
                                  "reports it), from the contact impulses on the vane beads, averaged over the "
                                  "steps since the previous row");
    tm.emplace_back("sampling", every_rad_ > 0
                                    ? fmt::format("a row each time phi has changed by {} rad since the previous row "
                                                  "(time and angle at the row's step)",
                                                  io::format_number(every_rad_))
                                    : std::string("every step"));
    csv_.emplace(out, tm, std::vector<std::string>{"time_s", "angle_rad", "torque_N_m"});
  }
  /// After each step; `last`: the run's last step (a row whatever the angle).
  void step(const sim::World& w, bool last) {
    const double h = w.options().time_step;
    impulse_ += whole_torque(w) * h;
    time_ += h;
    const double phi = w.rotor_angle(0);
    if (every_rad_ == 0 || std::abs(phi - phi_last_) >= every_rad_ || last) {
      csv_->row(std::vector<double>{w.time(), phi, impulse_ / time_});
      impulse_ = time_ = 0.0;
      phi_last_ = phi;
    }
  }

 private:
  std::optional<io::CsvWriter> csv_;
  double every_rad_ = 0.0, impulse_ = 0.0, time_ = 0.0, phi_last_ = 0.0;
};

/// Per drive cycle of the vane (f > 0): the torque's fundamental amplitude and the
/// solver's work (cycles.csv), and the early stop of a pre-shear (vane.stop_change).
class CycleLog {
 public:
  CycleLog(std::ostream& out, core::Metadata cm, double stop_change, const sim::World& w,
           std::vector<double>& amplitudes)
      : stop_change_(stop_change), amplitudes_(amplitudes), current_(cycle_of(w, w.time())),
        wall_(std::chrono::steady_clock::now()) {
    cm.emplace_back("cycle", "floor(f (t - t_start)) of the vane's drive; a row per whole cycle of this run");
    cm.emplace_back("torque_amplitude_N_m", "amplitude of the fundamental of the motor torque over the cycle "
                                            "(per-step torques against cos and sin of 2 pi f t)");
    cm.emplace_back("stop_change", io::format_number(stop_change));
    csv_.emplace(out, cm,
                 std::vector<std::string>{"cycle", "torque_amplitude_N_m", "mean_sweeps_per_step", "cap_hits",
                                          "max_overlap_over_d", "wall_s"});
  }
  /// After each step; true once a whole cycle has ended with it.
  bool step(const sim::World& w, const sim::StepDiagnostics& d) {
    const sim::Rotor& r = w.rotor(0);
    const double t_mid = w.time() - 0.5 * w.options().time_step;  // the step's torque acts over it
    const double a = 2.0 * std::numbers::pi * r.f_Hz * (t_mid - r.t_start);
    sums_.c += whole_torque(w) * std::cos(a);
    sums_.s += whole_torque(w) * std::sin(a);
    sums_.sweeps += d.iterations;
    sums_.caps += d.hit_iteration_cap ? 1 : 0;
    sums_.overlap = std::max(sums_.overlap, d.max_overlap);
    ++sums_.steps;
    const std::int64_t now_cycle = cycle_of(w, w.time());
    if (now_cycle == current_) return false;
    const double n = static_cast<double>(sums_.steps);
    const double amp = 2.0 / n * std::hypot(sums_.c, sums_.s);
    const auto now = std::chrono::steady_clock::now();
    csv_->row(std::vector<std::string>{std::to_string(current_), io::format_number(amp),
                                       io::format_number(sums_.sweeps / n), std::to_string(sums_.caps),
                                       io::format_number(sums_.overlap),
                                       fmt::format("{:.3f}", std::chrono::duration<double>(now - wall_).count())});
    wall_ = now;
    amplitudes_.push_back(amp);
    sums_ = Sums{};
    current_ = now_cycle;
    return true;
  }
  /// Steady: three consecutive changes of the amplitude below stop_change.
  [[nodiscard]] bool steady() const {
    if (!(stop_change_ > 0) || amplitudes_.size() < 4) return false;
    bool steady = true;
    for (std::size_t q = amplitudes_.size() - 3; q < amplitudes_.size(); ++q)
      steady = steady && std::abs(amplitudes_[q] - amplitudes_[q - 1]) <= stop_change_ * amplitudes_[q];
    return steady;
  }

 private:
  static std::int64_t cycle_of(const sim::World& w, double t) {
    const sim::Rotor& r = w.rotor(0);
    return static_cast<std::int64_t>(std::floor(r.f_Hz * (t - r.t_start) + 1e-9));
  }
  struct Sums {
    double c = 0, s = 0, sweeps = 0, overlap = 0;
    std::int64_t steps = 0, caps = 0;
  };
  std::optional<io::CsvWriter> csv_;
  double stop_change_ = 0.0;
  std::vector<double>& amplitudes_;  ///< per whole cycle
  std::int64_t current_ = 0;
  Sums sums_;
  std::chrono::steady_clock::time_point wall_;
};

/// The virtual top camera ([camera]): surface.h5, one pair per frame interval, frames
/// at the steps nearest k / fps from the run's start; and frames.h5, the bodies at every
/// camera frame (record k is frame k of surface.h5), with the scene a renderer needs
/// (pipeline/sim_render_job.hpp, synth/cup_view.hpp).
class CameraRecorder {
 public:
  CameraRecorder(io::AtomicOutputSet& out, const sim::SceneCamera& cam, bool frames, const sim::World& w,
                 const core::Metadata& meta, int beads_per_chain, const std::vector<std::int64_t>& chain_ids)
      : cam_(cam), frame_s_(1.0 / cam.fps), t_first_(w.time()), t_frame_(w.time()), first_step_(w.steps_done()) {
    surface_.emplace(out.add("surface.h5").temp_path());
    camera_.emplace(cam.options);
    camera_->record(w);
    next_frame_step_ = w.steps_done() + std::llround(frame_s_ / w.options().time_step);
    if (frames) {
      core::Metadata fm = meta;
      sim::add_frames_metadata(fm, cam, beads_per_chain, w);
      frames_.emplace(out.add("frames.h5").temp_path(), w, fm, chain_ids);
      frames_->append(w);
    }
  }
  /// After each step: a pair (and a frame record) when the step is a camera frame.
  void step(const sim::World& w) {
    if (w.steps_done() != next_frame_step_) return;
    const double h = w.options().time_step;
    const core::VectorField f = camera_->pair(w);
    surface_->append(f, frame_, frame_ + 1, t_frame_, w.time() - t_frame_);
    if (frames_) frames_->append(w);
    ++frame_;
    t_frame_ = w.time();
    next_frame_step_ = first_step_ + std::llround((t_first_ + static_cast<double>(frame_ + 1) * frame_s_) / h) -
                       std::llround(t_first_ / h);
  }
  [[nodiscard]] bool has_pair() const { return surface_->started(); }
  /// Closes both files: surface.h5 with its geometry and drive attributes.
  void close(const sim::World& w, const core::Metadata& meta, int beads_per_chain, const std::string& scene) {
    if (!surface_->started())  // no frame interval in the run: an empty field file is refused
      throw NoResultError(fmt::format("{}: the run holds no frame interval of the camera ({} s): run longer than "
                                      "1/fps or drop [camera]",
                                      scene, io::format_number(frame_s_)));
    const sim::SurfaceCameraOptions& co = cam_.options;
    io::FieldFileWriter& s = *surface_;
    s.set_attribute("fps", cam_.fps);
    s.set_attribute("m_per_px", co.m_per_px);
    s.set_attribute("centre_x_px", co.centre_x_px);
    s.set_attribute("centre_y_px", co.centre_y_px);
    s.set_attribute("cup_radius_px", co.cup_radius_m / co.m_per_px);
    s.set_attribute("vane_radius_px", co.vane_radius_m / co.m_per_px);
    s.set_attribute("N", static_cast<double>(beads_per_chain));
    if (w.rotor_count() > 0) {
      const sim::Rotor& r = w.rotor(0);
      s.set_attribute("f_Hz", r.f_Hz);
      s.set_attribute("phi0_rad", r.phi0);
      // phi = phi0 sin(2 pi f (t - t_start) + phase) = phi0 sin(2 pi f t + vane_phase_rad)
      s.set_attribute("vane_phase_rad", r.phase - 2.0 * std::numbers::pi * r.f_Hz * r.t_start);
    }
    s.set_attribute("source", "shearzone sim: virtual top camera (exact surface motion)");
    s.set_attribute("run_id", core::metadata_value(meta, "run_id"));
    // No measurement noise (float32 rounding only: 6e-8 relative): profile takes the
    // beads' radial motion as motion, not as the noise floor.
    s.set_attribute("noise_sigma_px", 0.0);
    std::string conv;
    for (const auto& [k, v] : meta) conv += k + ": " + v + "\n";
    s.set_attribute("options", conv);
    s.set_attribute("surface", "each node sees the top-most mobile bead whose horizontal disc contains it; "
                               "u_px, v_px: displacement of that material point from frame a to frame b "
                               "(x right = +X, y down = -Y, seen from above); masked: vane disc and outside "
                               "the cup; invalid: no bead");
    s.close();
    if (frames_) frames_->close();
  }

 private:
  const sim::SceneCamera& cam_;
  double frame_s_ = 0.0, t_first_ = 0.0, t_frame_ = 0.0;
  std::int64_t first_step_ = 0, frame_ = 0, next_frame_step_ = 0;
  std::optional<io::FieldFileWriter> surface_;
  std::optional<sim::SurfaceCamera> camera_;
  std::optional<sim::SnapshotWriter> frames_;
};

}  // namespace

SimJobSummary run_sim_job(const SimJobOptions& o, const core::Metadata& header,
                          const core::ProgressCallback& progress, const sim::FillProgress& fill_progress) {
  SimJobSummary sum;
  RunWorld run = open_world(o, fill_progress, sum);
  const sim::LoadedScene& scene = run.scene;
  const sim::SceneCadence cad = scene.cadence;
  sim::World& w = *run.world;
  const bool branch = start_branch(o, w);
  count_bodies(w, sum);
  const std::int64_t last_step = end_step(o, w, cad, branch);
  const std::int64_t todo = std::max<std::int64_t>(0, last_step - w.steps_done());
  const core::Metadata meta = run_metadata(o, header, w, last_step, branch, sum);

  io::AtomicOutputSet out(o.output_dir, o.force);
  io::AtomicOutput& snap_file = out.add("snapshots.h5");
  io::AtomicOutput& xdmf_file = out.add("snapshots.xdmf");
  io::AtomicOutput& diag_file = out.add("diagnostics.csv");
  out.check("checkpoint.h5");
  io::AtomicOutput* ckpt_file = nullptr;
  std::optional<TorqueLog> torque;
  if (w.rotor_count() > 0) torque.emplace(out.add("torque.csv").stream(), meta, scene, w);
  std::optional<CameraRecorder> camera;
  if (scene.camera)
    camera.emplace(out, *scene.camera, scene.camera->frames && o.camera_frames, w, meta, scene.beads_per_chain,
                   run.chain_ids);
  std::optional<CycleLog> cycles;
  if (w.rotor_count() > 0 && w.rotor(0).f_Hz > 0)
    cycles.emplace(out.add("cycles.csv").stream(), meta, scene.stop_change, w, sum.torque_amplitudes);
  sim::SnapshotWriter snaps(snap_file.temp_path(), w, meta, run.chain_ids);
  sim::DiagnosticsCsv diag(diag_file.stream(), meta);
  auto checkpoint = [&] {
    if (ckpt_file == nullptr) ckpt_file = &out.add("checkpoint.h5");
    sim::write_checkpoint(ckpt_file->temp_path(), w, meta);
    ++sum.checkpoints;
  };
  auto finish_files = [&] {
    if (camera) camera->close(w, meta, scene.beads_per_chain, o.scene.string());
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
      if (camera) camera->step(w);
      if (cycles && cycles->step(w, d)) {
        ++sum.cycles_done;
        if (cycles->steady()) sum.stopped_steady = true;
      }
      if (torque) torque->step(w, k == todo || sum.stopped_steady);
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
    if (camera && !camera->has_pair()) throw;
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
