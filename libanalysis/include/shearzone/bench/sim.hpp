// shearzone/bench/sim.hpp: the contact-dynamics engine benchmark.
//
// Packing (one per bead count, deterministic from the seed): single glass beads
// (d = 2 mm, ρ = 2500 kg/m³, μ = 0.3 between beads and with the walls) on a jittered
// lattice (horizontal pitch 1.2 d with ±0.1 d jitter, layer pitch 1.2 d, alternate
// layers shifted by half a pitch) in a box with a square floor sized for the count
// (floor and four side walls, no lid; about as tall as wide), dropped under gravity
// with a cheap solver (h = 5e-4 s, tolerance 1e-2, at most 30 sweeps) until the
// translational kinetic energy per bead falls below 1e-3 m g d (at least the time to
// close the lattice gaps, at most settle_max_steps), then relaxed with the measured h,
// tolerance and cap on one thread (at least relax_min_steps, until a step converges with
// a kinetic energy per bead below 1e-5 m g d, at most relax_max_steps): the cheap drop
// leaves the beads jiggling, and the target is a packing at rest (sim::settle_lattice_pour,
// sim/scenario.hpp). The relaxed state is then carried (positions, velocities and the
// impulses, scaled by the new h over the old: sim::at_time_step) into worlds with the
// measured options (World::from_state).
//  1. Speed (sim_speed.csv): per bead count and thread count, `warmup_steps` untimed then `steps` timed
//     steps with h, tolerance and iteration cap (warm-started); wall-clock seconds of the
//     timed steps only. row_updates counts every row visit of the NLGS sweeps,
//     active_row_updates only the local solves of active rows (StepDiagnostics).
//  2. Accuracy (sim_accuracy.csv): on the packing of `accuracy_beads`, a grid of time
//     steps × iteration caps, each run for the same simulated time `accuracy_duration_s`
//     from the same settled state: mean sweeps and final residual per step, the largest
//     overlap / d over the run, the kinetic energy at its end and the seconds per step.
// The accuracy table runs on one thread.
//
// With `scene` set (`shearzone bench sim --scene cup|FILE`), the sheared vane cup instead
// (sim_cup.csv, run_cup_bench): per chain length N, the cup is filled and relaxed (the
// scene's settled fill, one thread: its wall time and steps are reported), the vane is
// set to phi = phi0 sin(2 pi f t) from the relaxed packing (t = 0: the vane at its fastest),
// `warmup_steps` steps run untimed on one thread, then from that sheared state each
// thread count runs `steps` timed steps (h, tolerance, cap and freeze_sweeps of the
// speed table). "cup" is the paper's cup: d = 2.4 mm steel
// beads (7800 kg/m³), mu = 0.2, cup radius 14.5 d, vane radius 4.5 d (four blades),
// chains of N beads (l_max = 0.4 mm, theta_max = 40 deg), cup_beads beads in all, filled
// to a height of cup_beads (pi/6) d³ / (0.6 pi (R² - R_v²)) (about 22 d for 15 000), wall
// and vane 3 d taller; its scene is written beside the CSV (cup_N<N>.toml) so a run can
// repeat it with `shearzone sim`. A FILE is any scene with a [vane] (its own N).
// `--scene stir` is the peer benchmark's stirred box instead (sim_stir.csv,
// run_stir_bench): stir_beads single beads (d = 2.4 mm steel, mu = 0.2) settled in a
// 25 d x 25 d box, a rod of 25 kinematic beads along y at x = 3 d, 1 d below the 99.5th
// percentile of the bead heights, pushed along +x at 5 mm/s (mobile beads overlapping it
// removed), timed like the cup. `--scene plow`: the same with a full-height wall (the
// rod and the columns of beads below it down to the floor) instead of the rod
// (sim_plow.csv).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "shearzone/core/metadata.hpp"
#include "shearzone/core/progress.hpp"

namespace shearzone::bench {

struct BenchSimOptions {
  std::vector<int> beads = {2000, 5000, 10000};  ///< bead counts of the speed table
  std::vector<int> threads = {1};  ///< engine thread counts of the speed table
  int steps = 20;                  ///< timed steps per bead count
  int warmup_steps = 10;           ///< untimed steps before the timing (warm start)
  double time_step_s = 5e-4;       ///< h of the speed table
  double tolerance = 1e-4;         ///< NLGS tolerance (both tables)
  int max_iterations = 200;        ///< NLGS cap of the speed table
  int accuracy_beads = 2000;       ///< packing of the accuracy table
  std::vector<double> accuracy_time_steps_s = {2.5e-4, 5e-4, 1e-3};
  std::vector<int> accuracy_max_iterations = {25, 50, 100, 200};
  double accuracy_duration_s = 0.01;  ///< simulated time per accuracy setting
  std::int64_t settle_max_steps = 4000;
  std::int64_t relax_min_steps = 50;   ///< relaxation with the measured solver: at least
  std::int64_t relax_max_steps = 400;  ///< ... and at most this many steps
  int freeze_sweeps = 16;              ///< engine freeze_sweeps (0: no freezing)
  /// Engine solvers: "alternate" (NLGS, forward and backward sweeps in turn), "forward"
  /// (NLGS, always forward), "anderson" (forward sweeps with Anderson acceleration of
  /// depth `anderson_depth`). The packing tables use the first; the sheared scenes time
  /// each from the same sheared state. Anderson by default, as every scene (docs/sim.md,
  /// "Benchmark": fewer sweeps and less time on the packings and on every sheared scene).
  std::vector<std::string> solvers = {"anderson"};
  int anderson_depth = 3;
  std::uint64_t seed = 1;
  bool quick = false;  ///< a smoke run: small packings, few steps (overrides the above)
  // The sheared cup (scene non-empty): "cup" or a scene file with a [vane].
  std::string scene;
  std::vector<int> chain_lengths = {1, 9};  ///< N of the built-in cup
  int cup_beads = 15000;                    ///< beads of the built-in cup
  int stir_beads = 10000;                   ///< beads of --scene stir (the peer benchmark's box)
  int stir_side_d = 25;                     ///< its box side and rod length, d (--quick: 10)
  double phi0_rad = 0.3, f_Hz = 0.1;        ///< the vane's drive
  /// --scene cup --accuracy: the observables against the solver's settings (sim_cup_accuracy.csv).
  /// Per N: the fill, `preshear_cycles` cycles at --time-step and --tolerance, then from
  /// that state `cycles` cycles per (time step, tolerance) with the first solver and the
  /// cap `accuracy_cap`.
  bool cup_accuracy = false;
  std::vector<double> cup_tolerances = {1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5};
  std::vector<double> cup_time_steps_s = {1e-3, 5e-4};
  int cycles = 2;
  int preshear_cycles = 1;
  int accuracy_cap = 5000;
  /// The built-in cup as a periodic wedge of 1/cup_sectors with one blade (1: the whole
  /// cup; 4: a quarter, the cup's four-blade symmetry). Torques are the whole cup's.
  int cup_sectors = 1;
  /// --scene cup --sector-check: the quarter against the whole cup (sim_cup_sector.csv).
  /// Per N and fill seed, each geometry is filled, pre-sheared `preshear_cycles` cycles
  /// and measured over `cycles` cycles (torque amplitude, K'1, K''1, r_c) at --time-step
  /// and --tolerance with the first solver.
  bool sector_check = false;
  /// --sector-check --reference CSV: the whole cup's rows (sectors = 1) taken from an
  /// earlier sim_cup_sector.csv of the same protocol and bead count instead of run again
  /// (the whole cup is deterministic and costs 5x the quarter); empty: run both.
  std::filesystem::path sector_reference;
  std::vector<std::uint64_t> seeds = {1, 2, 3};
  std::filesystem::path out_dir;
  bool force = false;
};

struct BenchSimSummary {
  std::vector<std::filesystem::path> files;
  std::vector<std::string> lines;  ///< one line per bead count, for the terminal
};

/// Throws ConfigError for an option out of range, NoResultError if a packing diverges.
BenchSimSummary run_sim_bench(const BenchSimOptions& options, const core::Metadata& header,
                              const core::ProgressCallback& progress = {});

}  // namespace shearzone::bench
