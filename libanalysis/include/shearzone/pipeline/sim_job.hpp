// shearzone/pipeline/sim_job.hpp: `shearzone sim scene.toml -o run/`: a generic
// contact-dynamics scene (docs/sim.md) run to its duration, with
// snapshots (HDF5 + XDMF), checkpoints and the diagnostics CSV in one output folder.
//
// The scene file's keys and what they build: sim/scene.hpp.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "shearzone/core/metadata.hpp"
#include "shearzone/core/progress.hpp"
#include "shearzone/sim/scene.hpp"

namespace shearzone::pipeline {

struct SimJobOptions {
  std::filesystem::path scene;       ///< scene .toml
  std::filesystem::path output_dir;  ///< run folder
  std::filesystem::path restart;     ///< checkpoint .h5 to continue from (empty: none)
  bool force = false;
  /// An amplitude branch (with restart, a checkpoint holding a vane): the vane's drive
  /// becomes phi0 sin(2 pi f (t - t_ck)) from the checkpoint's time t_ck, and the run
  /// lasts `branch_cycles` cycles instead of the scene's duration. NaN: not a branch;
  /// f NaN: the checkpoint's frequency; cycles NaN: 3.
  double branch_phi0_rad = std::numeric_limits<double>::quiet_NaN();
  double branch_f_Hz = std::numeric_limits<double>::quiet_NaN();
  double branch_cycles = std::numeric_limits<double>::quiet_NaN();
  /// With a [camera] whose `frames` is true: write frames.h5, the bodies at every camera
  /// frame (what `shearzone sim render` draws). The protocol's pre-shear sets it false:
  /// its minutes of frames are not a measurement.
  bool camera_frames = true;
};

struct SimJobSummary {
  std::int64_t first_step = 0;  ///< step count at the start (0, or the checkpoint's)
  std::int64_t steps = 0;       ///< steps done in this run
  double time_s = 0.0;          ///< simulated time at the end
  int bodies = 0;
  int fixed_bodies = 0;
  int kinematic_bodies = 0;
  int walls = 0;
  int ropes = 0;
  int angles = 0;
  std::size_t snapshots = 0;
  std::size_t checkpoints = 0;
  std::int64_t iteration_cap_hits = 0;  ///< in this run
  double max_overlap_over_d = 0.0;      ///< over the run
  double wall_seconds = 0.0;  ///< the run (the fill stage: fill.seconds)
  std::uint64_t state_hash = 0;  ///< World::state_hash() at the end
  std::vector<double> torque_amplitudes;  ///< per whole drive cycle (cycles.csv), N m
  int threads = 1;               ///< sweep threads of the run (sim::Options::threads)
  std::int64_t cycles_done = 0;  ///< whole drive cycles in this run (a vane)
  bool stopped_steady = false;   ///< vane.stop_change met: the run stopped early
  // fill.settle = true (not on restart): the sim::fill stage before the run.
  sim::SceneFillReport fill;
};

/// Runs the scene. Throws ConfigError / InputError (scene, checkpoint, outputs exist)
/// before any work, and NoResultError naming the step and the bodies on divergence;
/// then the files written so far (diagnostics to the failing step, snapshots, the last
/// periodic checkpoint) are committed before the error propagates.
SimJobSummary run_sim_job(const SimJobOptions& options, const core::Metadata& header,
                          const core::ProgressCallback& progress = {}, const sim::FillProgress& fill_progress = {});

/// One stage of a protocol: "preshear" or a branch's folder name (phi0_0.300).
struct SimProtocolStage {
  std::string name;
  double phi0_rad = 0.0, f_Hz = 0.0;
  SimJobSummary summary;
};
struct SimProtocolSummary {
  std::vector<SimProtocolStage> stages;  ///< the pre-shear, then the branches in scene order
  std::filesystem::path checkpoint;      ///< the pre-sheared state the branches restart from
};

/// True when the scene file has a [protocol] section (sim/scene.hpp).
bool scene_has_protocol(const std::filesystem::path& scene);

/// `shearzone sim scene.toml --preshear -o pre/`: the protocol's pre-shear alone (the fill
/// and the drive of [protocol], no frames.h5), exactly what run_sim_protocol writes to
/// run/preshear/; a branch then restarts from pre/checkpoint.h5 (--restart, --phi0,
/// --f-hz, --cycles). A study runs the protocol this way, one job per stage.
SimJobSummary run_sim_preshear(const SimJobOptions& options, const core::Metadata& header,
                               const core::ProgressCallback& progress = {},
                               const sim::FillProgress& fill_progress = {});

/// `shearzone sim scene.toml -o run/` on a scene with [protocol]: the fill (fill.settle),
/// the pre-shear into run/preshear/ (a run_sim_job of the scene: torque.csv, cycles.csv,
/// surface.h5 with a [camera], checkpoint.h5), then per amplitude a branch restarted
/// from run/preshear/checkpoint.h5 into run/<SceneProtocol::branch_folder> (exactly what
/// `shearzone sim scene.toml --restart run/preshear/checkpoint.h5 --phi0 A --f-hz F
/// --cycles K -o run/phi0_A/` does), and run/protocol.csv (a row per stage). Every
/// folder is checked before the first step (ConfigError if one exists without force);
/// each stage commits its own folder, so a failing branch leaves the earlier ones whole
/// (and no protocol.csv). `on_stage` is told when each stage ends.
SimProtocolSummary run_sim_protocol(const SimJobOptions& options, const core::Metadata& header,
                                    const core::ProgressCallback& progress = {},
                                    const std::function<void(const SimProtocolStage&)>& on_stage = {},
                                    const sim::FillProgress& fill_progress = {});

}  // namespace shearzone::pipeline
