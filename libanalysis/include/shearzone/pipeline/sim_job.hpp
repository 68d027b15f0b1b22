// shearzone/pipeline/sim_job.hpp: `shearzone sim scene.toml -o run/`: a generic
// contact-dynamics scene (README, "Contact-dynamics engine") run to its duration, with
// snapshots (HDF5 + XDMF), checkpoints and the diagnostics CSV in one output folder.
//
// Scene TOML (strict keys; SI units in the names):
//     [sim]      duration_s (required), time_step_s, gravity_m_per_s2 = [x, y, z],
//                friction, tolerance, max_iterations, alert_margin, max_overlap,
//                max_rope_excess, max_angle_excess_deg
//     [output]   snapshot_every, checkpoint_every (steps; 0: none / only at the end),
//                diagnostics_every (steps)
//     [box]      min_m = [x, y, z], max_m = [x, y, z], friction, lid (bool):
//                floor, four sides (and a lid) as half-space walls
//     [cylinder] radius_m, height_m, bead_diameter_m, centre_m = [x, y], floor_friction:
//                a wall of fixed beads outside radius_m (rings touching, layers from z = 0)
//                and a floor plane at z = 0
//     [beads]    diameter_m, density_kg_per_m3, positions_m = [x0, y0, z0, x1, ...]
//                (mobile, explicit), fixed_positions_m = [...] (fixed beads)
//     [chains]   beads_per_chain (N: explicit positions are cut into chains of N
//                consecutive beads), l_max_m (bond slack: bond length ≤ d + l_max),
//                max_angle_deg (turning-angle limit; 180: none)
//     [fill]     count (chains), min_m, max_m (box region), seed, clearance:
//                random non-overlapping chains of [chains] (sim::place_chains),
//                placed loosely and left to fall
// With `restart`, the world (bodies, walls, chains, options, impulses) comes from the
// checkpoint and the scene gives only the duration (total simulated time) and the
// output cadence; the body and wall sections are still checked but not used.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>

#include "shearzone/core/metadata.hpp"
#include "shearzone/core/progress.hpp"

namespace shearzone::pipeline {

struct SimJobOptions {
  std::filesystem::path scene;       ///< scene .toml
  std::filesystem::path output_dir;  ///< run folder
  std::filesystem::path restart;     ///< checkpoint .h5 to continue from (empty: none)
  bool force = false;
};

struct SimJobSummary {
  std::int64_t first_step = 0;  ///< step count at the start (0, or the checkpoint's)
  std::int64_t steps = 0;       ///< steps done in this run
  double time_s = 0.0;          ///< simulated time at the end
  int bodies = 0;
  int walls = 0;
  int ropes = 0;
  int angles = 0;
  std::size_t snapshots = 0;
  std::size_t checkpoints = 0;
  std::int64_t iteration_cap_hits = 0;  ///< in this run
  double max_overlap_over_d = 0.0;      ///< over the run
  double wall_seconds = 0.0;
  std::uint64_t state_hash = 0;  ///< World::state_hash() at the end
};

/// Runs the scene. Throws ConfigError / InputError (scene, checkpoint, outputs exist)
/// before any work, and NoResultError naming the step and the bodies on divergence;
/// then the files written so far (diagnostics to the failing step, snapshots, the last
/// periodic checkpoint) are committed before the error propagates.
SimJobSummary run_sim_job(const SimJobOptions& options, const core::Metadata& header,
                          const core::ProgressCallback& progress = {});

}  // namespace shearzone::pipeline
