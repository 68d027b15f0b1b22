// shearzone/sim/scene.hpp: the scene TOML of `shearzone sim`, read and built here only.
//
// Scene TOML (strict keys; SI units in the names):
//     [sim]      duration_s (required; not with [protocol]), time_step_s,
//                gravity_m_per_s2 = [x, y, z], friction (0.5; 0.2 in a scene with a
//                [vane], as cylinder.floor_friction: the paper's oiled chains),
//                tolerance, max_iterations, alert_margin, max_overlap,
//                max_rope_excess, max_angle_excess_deg,
//                freeze_sweeps (integer in [0, 1e6], default 16: sweeps a quiet
//                zero-impulse row is skipped; 0: never freeze),
//                threads (integer in [1, 256], default 1: the engine's slab-parallel
//                sweep; bit-identical runs for a fixed count, another count is another
//                Gauss–Seidel order), sweep_order ("forward", the default: always
//                forward; "alternate": forward and backward in turn), anderson_depth
//                (integer in [0, 10], default 3: Anderson acceleration of the sweeps
//                over this many columns; 0: plain NLGS). The defaults are the fastest
//                solver measured on every kind of scene (docs/sim.md, "Solver"); the
//                engine's own World::Options keep alternating NLGS
//     [output]   snapshot_every, checkpoint_every (steps; 0: none / only at the end),
//                diagnostics_every (steps)
//     [box]      min_m = [x, y, z], max_m = [x, y, z], friction, lid (bool):
//                floor, four sides (and a lid) as half-space walls
//     [cylinder] radius_m, height_m, bead_diameter_m, centre_m = [x, y], floor_friction,
//                rough_floor (false): a wall of fixed beads outside radius_m (rings
//                touching, layers from z = 0) and a floor plane at z = 0; rough_floor
//                adds a layer of touching fixed beads (triangular lattice, centres on the
//                plane, centres within radius_m), and the fill and the vane's layers then
//                start at their tops (z = bead_diameter_m / 2); sectors (1: the whole cup;
//                3..64: a periodic wedge of 1/sectors of the cup, azimuth from -pi/sectors,
//                World's "Periodic sector": wall rings of a multiple of sectors beads, the
//                fill, floor beads and vane beads of that wedge only; needs the cylinder
//                fill, a [vane] of that many blades on the axis (blade 0 in the wedge's
//                middle) and every drive amplitude below pi/sectors; torques are logged
//                as the whole cup's, sectors x the wedge's); chains longer than 9
//                beads only with sector_chains = true (validated for N = 1 and 9)
//     [beads]    diameter_m, density_kg_per_m3, positions_m = [x0, y0, z0, x1, ...]
//                (mobile, explicit), fixed_positions_m = [...] (fixed beads),
//                kinematic_positions_m = [...] (kinematic beads, prescribed motion),
//                kinematic_velocity_m_per_s = [vx, vy, vz] and
//                kinematic_angular_velocity_rad_per_s = [wx, wy, wz] (default 0; the
//                same constant v and ω for every kinematic bead: the engine moves them by
//                x += h v, they push mobile beads and never feel a force)
//     [chains]   beads_per_chain (N: explicit positions are cut into chains of N
//                consecutive beads), l_max_m (bond slack: bond length ≤ d + l_max),
//                max_angle_deg (turning-angle limit; 180: none)
//     [fill]     count (chains), min_m, max_m (box region inside the container), seed,
//                clearance: random non-overlapping chains of [chains] (sim::place_chains).
//                settle = false (default): placed loosely in the region and left to fall
//                during the run.
//                settle = true: sim::fill builds a settled packing first: the chains are
//                placed in the region raised until they fill insert_fraction (default 0.2)
//                of it, dropped with a cheap solver (settle_tolerance 1e-2,
//                settle_max_iterations 30) until ½ m v² per bead < settle_kinetic_energy
//                (1e-3) m g d or settle_max_steps (20000), then relaxed with the [sim]
//                options until ½ m v² per bead < relax_kinetic_energy (1e-5) m g d or
//                relax_max_steps (20000); the drop also ends once its kinetic energy
//                stops falling after the fall time (plateau_ratio 0.7, 0: off; see
//                sim::FillOptions). The container ([box] walls with their lid, or the
//                [cylinder] beads and floor, fixed and kinematic beads) is the same in the
//                drop and relaxation worlds; kinematic beads stand still during the fill.
//                The run then starts from the relaxed packing at step 0, t = 0 (the fill's
//                steps are not counted; its last impulses are the warm start), and the
//                kinematic beads start moving. Not with explicit mobile positions_m, needs
//                a container and gravity with a downward component, and under a lid the
//                raised drop column must fit. The settle/relax keys are refused without
//                settle = true. Either way the region must lie inside the box or cylinder
//                and clear of the scene's other beads (placement does not see them; with
//                settle, the whole raised column).
//     [vane]     radius_m, height_m (required for a vane), blades (4), centre_m = [x, y]
//                (default: the cylinder's centre, else the origin), phi0_rad, f_Hz,
//                phase_rad, torque_every_rad (1e-3; 0: every step): a rigid rotor of
//                kinematic beads of beads.diameter_m about the vertical axis (a hub bead
//                and, per blade, touching beads at r = d, 2d, ... while the tip's edge is
//                within radius_m; layers from the floor up to height_m), turned by
//                phi(t) = phi0 sin(2 pi f t + phase) (World::add_rotor): exact positions,
//                the motor torque logged (sim job: torque.csv). It stands still during a
//                settled fill. stop_change (0: off): stop the run once the torque
//                amplitude per cycle changed by less than this fraction over 3
//                consecutive cycles (a pre-shear that has reached its steady state).
//     [camera]   fps (25), m_per_px (default d/10), spacing_px (8): a virtual camera
//                looking down into the [cylinder] (required): the sim job writes the
//                surface field surface.h5 in the PIV field layout, one pair per frame
//                interval (sim/surface.hpp), masked on the vane and outside the cup.
//     [protocol] phi0_rad = [a0, a1, ...] (required, each in (0, 100] rad),
//                f_Hz (0.1), cycles (3), preshear_phi0_rad (pi/50), preshear_f_Hz (1),
//                preshear_s (240), stop_change (0.01; 0: the whole pre-shear): the
//                paper's protocol (SceneProtocol, pipeline::run_sim_protocol). Needs a
//                [vane]; sim.duration_s and vane.phi0_rad, f_Hz, phase_rad and stop_change
//                are refused (the protocol sets them): the world is built with the
//                pre-shear drive and duration_s = preshear_s.
// Bodies are numbered: cylinder wall beads, fixed beads, kinematic beads, explicit mobile
// chains, fill chains; every fixed or kinematic bead is a chain of its own (chain_id).
// Lengths in bead diameters: cylinder.radius_d, cylinder.height_d, vane.radius_d,
// vane.height_d and fill.height_d may replace the _m key (× beads.diameter_m; one of
// the two). cylinder.height_m is required; cylinder.bead_diameter_m defaults to
// beads.diameter_m.
// Bad values (out of range, wrong type, wrong count) are one ConfigError line naming
// file:line and key.
// With `restart`, the world (bodies, walls, chains, options including threads and
// freeze_sweeps, impulses) comes from the checkpoint and the scene gives only the
// duration (total simulated time) and the output cadence; the body and wall sections
// are still checked but not used (no placement and no fill).
#pragma once

#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "shearzone/core/progress.hpp"
#include "shearzone/sim/builder.hpp"
#include "shearzone/sim/surface.hpp"
#include "shearzone/sim/world.hpp"

namespace shearzone::sim {

/// The vane's drive phi0 sin(2 pi f t) is imposed once per time step h: with fewer than
/// this many steps per period (f h > 1/20) the angle is sampled towards an alias (at
/// f h = 1 it does not move at all) while the torque log states the requested f.
/// Scenes and branches beyond it are refused.
inline constexpr double kMinStepsPerDrivePeriod = 20.0;
/// The most time steps one run (a pre-shear, a branch) may take.
inline constexpr double kMaxRunSteps = 1e9;


/// Duration and output cadence ([sim] duration_s, [output]).
struct SceneCadence {
  double duration_s = 0.0;
  std::int64_t snapshot_every = 100, checkpoint_every = 0, diagnostics_every = 1;
};

/// What the fill stage (fill.settle = true) reported.
struct SceneFillReport {
  bool settled = false;               ///< the fill stage ran
  std::int64_t settle_steps = 0;      ///< drop steps (cheap solver)
  std::int64_t settle_cap_hits = 0;   ///< iteration-cap hits of the drop (expected)
  bool settle_plateau = false;        ///< the drop ended on its plateau (FillOptions::plateau_ratio)
  std::int64_t relax_steps = 0;       ///< relaxation steps ([sim] options)
  bool relaxed = false;               ///< relax_kinetic_energy reached
  double kinetic_energy = 0.0;        ///< final ½ m v² per bead / (m g d)
  double seconds = 0.0;               ///< wall time of the fill stage
};

/// [camera]: the virtual top camera of the surface field (sim/surface.hpp).
struct SceneCamera {
  double fps = 25.0;
  SurfaceCameraOptions options;  ///< the image covers the cylinder, its axis at the centre
  /// camera.frames: write frames.h5, the bodies at every camera frame, from which
  /// `shearzone sim render` draws the video (pipeline/sim_render_job.hpp).
  bool frames = true;
  // The scene the renderer draws, in SI units (the cup's axis at options.cx_m, cy_m).
  double bead_diameter_m = 0.0;
  double cup_height_m = 0.0;
  int vane_blades = 0;             ///< 0: no vane
  double vane_height_m = 0.0;
};

/// [protocol]: the paper's protocol in one scene (pipeline::run_sim_protocol): fill and
/// relax (fill.settle), pre-shear phi = preshear_phi0_rad sin(2 pi preshear_f_Hz t) for
/// preshear_s (stopped early once the torque amplitude is steady to stop_change over 3
/// cycles; 0: never), checkpoint, then per amplitude in phi0_rad a branch of `cycles`
/// cycles at f_Hz restarted from that checkpoint, in its own folder (branch_folder).
struct SceneProtocol {
  double preshear_phi0_rad = 3.14159265358979323846 / 50.0;
  double preshear_f_Hz = 1.0;
  double preshear_s = 240.0;
  double stop_change = 0.01;
  std::vector<double> phi0_rad;  ///< > 0, distinct folder names
  double f_Hz = 0.1;
  double cycles = 3.0;
  /// The branch's folder: phi0_0.300 (three decimals when they hold the value exactly,
  /// else the shortest exact form, e.g. phi0_0.0025).
  static std::string branch_folder(double phi0_rad);
};

/// A scene file's keys as values: one member per key, in the file's sections and units
/// (the header above), each absent unless set (absent: the documented default). read_scene
/// makes one of a file, write_scene writes one as a file, and build_scene checks every
/// key and every rule between sections and builds its world; so code (a benchmark, a
/// study, Python) builds a scene as values and the file it writes reads back the same.
struct SceneSpec {
  template <class T>
  using Key = std::optional<T>;
  using Numbers = std::vector<double>;  ///< a list ([x, y, z], positions x0, y0, z0, ...)
  struct Sim {
    Key<double> duration_s, time_step_s;
    Key<Numbers> gravity_m_per_s2;
    Key<double> friction, tolerance;
    Key<std::int64_t> max_iterations;
    Key<double> alert_margin, max_overlap, max_rope_excess, max_angle_excess_deg;
    Key<std::int64_t> freeze_sweeps, threads;
    Key<std::string> sweep_order;
    Key<std::int64_t> anderson_depth;
  } sim;
  struct Output {
    Key<std::int64_t> snapshot_every, checkpoint_every, diagnostics_every;
  } output;
  struct Box {
    Key<Numbers> min_m, max_m;
    Key<double> friction;
    Key<bool> lid;
  } box;
  struct Cylinder {
    Key<double> radius_m, radius_d, height_m, height_d, bead_diameter_m;
    Key<Numbers> centre_m;
    Key<double> floor_friction;
    Key<bool> rough_floor;
    Key<std::int64_t> sectors;
    Key<bool> sector_chains;
  } cylinder;
  struct Beads {
    Key<double> diameter_m, density_kg_per_m3;
    Key<Numbers> positions_m, fixed_positions_m, kinematic_positions_m, kinematic_velocity_m_per_s,
        kinematic_angular_velocity_rad_per_s;
  } beads;
  struct Chains {
    Key<std::int64_t> beads_per_chain;
    Key<double> l_max_m, max_angle_deg;
  } chains;
  struct Fill {
    Key<std::int64_t> count;
    Key<Numbers> min_m, max_m;
    Key<std::int64_t> seed;
    Key<double> clearance;
    Key<bool> settle;
    Key<double> insert_fraction, settle_tolerance;
    Key<std::int64_t> settle_max_iterations, settle_max_steps;
    Key<double> settle_kinetic_energy, relax_kinetic_energy;
    Key<std::int64_t> relax_max_steps;
    Key<double> plateau_ratio, height_m, height_d;
  } fill;
  struct Vane {
    Key<std::int64_t> blades;
    Key<double> radius_m, radius_d, height_m, height_d;
    Key<Numbers> centre_m;
    Key<double> phi0_rad, f_Hz, phase_rad, torque_every_rad, stop_change;
  } vane;
  struct Camera {
    Key<double> fps, m_per_px, spacing_px;
    Key<bool> frames;
  } camera;
  struct Protocol {
    Key<double> preshear_phi0_rad, preshear_f_Hz, preshear_s, stop_change;
    Key<Numbers> phi0_rad;
    Key<double> f_Hz, cycles;
  } protocol;

  /// Where the values came from, for messages: a refused key reads
  /// "<source>:<line>: key "<name>": ..." with the key's line in `lines` (read_scene
  /// fills both), or "<source>: key "<name>": ..." for a spec without lines.
  std::string source = "the scene";
  std::map<std::string, std::size_t> lines;

  /// Calls f(name, member) for every key, in the order write_scene writes them
  /// ("sim.duration_s", sim.duration_s), ...: the one list of the scene file's keys.
  template <class Spec, class F>
  static void for_each_key(Spec& spec, F&& f);
};

template <class Spec, class F>
void SceneSpec::for_each_key(Spec& s, F&& f) {
  f("sim.duration_s", s.sim.duration_s);
  f("sim.time_step_s", s.sim.time_step_s);
  f("sim.gravity_m_per_s2", s.sim.gravity_m_per_s2);
  f("sim.friction", s.sim.friction);
  f("sim.tolerance", s.sim.tolerance);
  f("sim.max_iterations", s.sim.max_iterations);
  f("sim.alert_margin", s.sim.alert_margin);
  f("sim.max_overlap", s.sim.max_overlap);
  f("sim.max_rope_excess", s.sim.max_rope_excess);
  f("sim.max_angle_excess_deg", s.sim.max_angle_excess_deg);
  f("sim.freeze_sweeps", s.sim.freeze_sweeps);
  f("sim.threads", s.sim.threads);
  f("sim.sweep_order", s.sim.sweep_order);
  f("sim.anderson_depth", s.sim.anderson_depth);
  f("output.snapshot_every", s.output.snapshot_every);
  f("output.checkpoint_every", s.output.checkpoint_every);
  f("output.diagnostics_every", s.output.diagnostics_every);
  f("box.min_m", s.box.min_m);
  f("box.max_m", s.box.max_m);
  f("box.friction", s.box.friction);
  f("box.lid", s.box.lid);
  f("cylinder.radius_m", s.cylinder.radius_m);
  f("cylinder.radius_d", s.cylinder.radius_d);
  f("cylinder.height_m", s.cylinder.height_m);
  f("cylinder.height_d", s.cylinder.height_d);
  f("cylinder.bead_diameter_m", s.cylinder.bead_diameter_m);
  f("cylinder.centre_m", s.cylinder.centre_m);
  f("cylinder.floor_friction", s.cylinder.floor_friction);
  f("cylinder.rough_floor", s.cylinder.rough_floor);
  f("cylinder.sectors", s.cylinder.sectors);
  f("cylinder.sector_chains", s.cylinder.sector_chains);
  f("beads.diameter_m", s.beads.diameter_m);
  f("beads.density_kg_per_m3", s.beads.density_kg_per_m3);
  f("beads.positions_m", s.beads.positions_m);
  f("beads.fixed_positions_m", s.beads.fixed_positions_m);
  f("beads.kinematic_positions_m", s.beads.kinematic_positions_m);
  f("beads.kinematic_velocity_m_per_s", s.beads.kinematic_velocity_m_per_s);
  f("beads.kinematic_angular_velocity_rad_per_s", s.beads.kinematic_angular_velocity_rad_per_s);
  f("chains.beads_per_chain", s.chains.beads_per_chain);
  f("chains.l_max_m", s.chains.l_max_m);
  f("chains.max_angle_deg", s.chains.max_angle_deg);
  f("fill.count", s.fill.count);
  f("fill.min_m", s.fill.min_m);
  f("fill.max_m", s.fill.max_m);
  f("fill.seed", s.fill.seed);
  f("fill.clearance", s.fill.clearance);
  f("fill.settle", s.fill.settle);
  f("fill.insert_fraction", s.fill.insert_fraction);
  f("fill.settle_tolerance", s.fill.settle_tolerance);
  f("fill.settle_max_iterations", s.fill.settle_max_iterations);
  f("fill.settle_max_steps", s.fill.settle_max_steps);
  f("fill.settle_kinetic_energy", s.fill.settle_kinetic_energy);
  f("fill.relax_kinetic_energy", s.fill.relax_kinetic_energy);
  f("fill.relax_max_steps", s.fill.relax_max_steps);
  f("fill.plateau_ratio", s.fill.plateau_ratio);
  f("fill.height_m", s.fill.height_m);
  f("fill.height_d", s.fill.height_d);
  f("vane.blades", s.vane.blades);
  f("vane.radius_m", s.vane.radius_m);
  f("vane.radius_d", s.vane.radius_d);
  f("vane.height_m", s.vane.height_m);
  f("vane.height_d", s.vane.height_d);
  f("vane.centre_m", s.vane.centre_m);
  f("vane.phi0_rad", s.vane.phi0_rad);
  f("vane.f_Hz", s.vane.f_Hz);
  f("vane.phase_rad", s.vane.phase_rad);
  f("vane.torque_every_rad", s.vane.torque_every_rad);
  f("vane.stop_change", s.vane.stop_change);
  f("camera.fps", s.camera.fps);
  f("camera.m_per_px", s.camera.m_per_px);
  f("camera.spacing_px", s.camera.spacing_px);
  f("camera.frames", s.camera.frames);
  f("protocol.preshear_phi0_rad", s.protocol.preshear_phi0_rad);
  f("protocol.preshear_f_Hz", s.protocol.preshear_f_Hz);
  f("protocol.preshear_s", s.protocol.preshear_s);
  f("protocol.stop_change", s.protocol.stop_change);
  f("protocol.phi0_rad", s.protocol.phi0_rad);
  f("protocol.f_Hz", s.protocol.f_Hz);
  f("protocol.cycles", s.protocol.cycles);
}

struct LoadedScene {
  std::optional<SceneProtocol> protocol;  ///< the scene has a [protocol]
  std::optional<SceneCamera> camera;  ///< the scene has a [camera]
  SceneCadence cadence;
  bool vane = false;               ///< the scene has a [vane] (rotor 0 of the world)
  double vane_f_Hz = 0.0;          ///< its drive's frequency (a protocol: the pre-shear's)
  double torque_every_rad = 1e-3;  ///< torque log sampling: a row per this change of phi (0: every step)
  /// Stop once the vane's torque amplitude changed by less than this fraction over 3
  /// consecutive whole cycles (0: run the whole duration); the pre-shear's early stop.
  double stop_change = 0.0;
  int beads_per_chain = 1;         ///< N, for the torque log's header
  std::optional<World> world;           ///< built (check_only: the container only)
  std::vector<std::int64_t> chain_ids;  ///< per body, for the snapshots
  SceneFillReport fill;
  double bead_diameter_m = 0.0;  ///< beads.diameter_m (every mobile bead)
  std::int64_t mobile_beads = 0;  ///< the scene's mobile beads: beads.positions_m and fill.count x N
};

/// Progress of the fill stage (sim::fill's drop and relaxation steps).
struct FillProgress {
  core::ProgressCallback drop, relax;
};

/// Reads a scene file and builds its world: build_scene(read_scene(scene), ...).
/// `check_only` (restart from a checkpoint): reads and checks every section but places,
/// drops and relaxes nothing. Throws ConfigError naming file:line and key for a bad value,
/// and InputError for beads that overlap at the start (a fresh scene only).
LoadedScene load_scene(const std::filesystem::path& scene, bool check_only, const FillProgress& progress = {});

/// The scene file's keys as values: the file parsed, every key known and of its type
/// (ConfigError naming file:line and key); the rules between keys are build_scene's.
SceneSpec read_scene(const std::filesystem::path& scene);
/// The spec as a scene file (sections in for_each_key's order, numbers in their shortest
/// exact form), after `comment` ("# ..." lines, may be empty): read_scene gives it back.
void write_scene(const SceneSpec& spec, std::ostream& out, const std::string& comment = {});
/// Checks every key and every rule between sections (ConfigError naming the spec's source,
/// line and key, as for a file) and builds the world: load_scene's second half.
/// `check_only`: the container only; else beads overlapping at the start are refused
/// (InputError naming the spec's source).
LoadedScene build_scene(const SceneSpec& spec, bool check_only, const FillProgress& progress = {});

/// The drive of an amplitude branch (`sim --restart CKPT --phi0 A --f-hz F --cycles K`)
/// on a world of `sectors` (0: the whole cup) and `time_step` s, starting at
/// `start_time_s`: |phi0| < pi/sectors (the blade stays in its wedge) and <= 100 rad,
/// 0 < f <= 1000 Hz with at least kMinStepsPerDrivePeriod steps per period, 0 < cycles
/// <= 1e6, and the branch's end within kMaxRunSteps steps. Throws ConfigError naming the
/// option at fault (--phi0, --f-hz, --cycles). A study checks its grid with it.
void validate_branch(int sectors, double time_step, double start_time_s, double phi0_rad, double f_Hz, double cycles);

/// A restart takes its world from a checkpoint while the run's outputs (surface.h5,
/// frames.h5, the torque log) describe the scene's cup and vane: the two must be the same
/// cup. `scene` is load_scene(.., check_only = true) (its world the container alone).
/// Checks the periodic sector, the walls, the container's beads (kind, diameter, the
/// fixed beads' and the vane's positions), the vane, and the count and diameter of the
/// mobile beads; throws InputError naming the first difference, else returns.
void check_checkpoint_matches(const LoadedScene& scene, const WorldState& checkpoint,
                              const std::filesystem::path& scene_path, const std::filesystem::path& checkpoint_path);

}  // namespace shearzone::sim
