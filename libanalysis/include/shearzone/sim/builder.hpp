// shearzone/sim/builder.hpp: the chain builder (random non-overlapping bead chains in a
// region, filled into a container by a cheap drop and a relaxation) and the packing
// fraction of mobile spheres inside a measurement region.
// Packing anchors (docs/sim.md, "Chain builder and packing"): poured frictional spheres at
// μ ≈ 0.2 pack loosely at φ ≈ 0.60–0.62 (Silbert, Soft Matter 6, 2918 (2010); Song, Wang &
// Makse, Nature 453, 629 (2008)), and φ falls with the chain length N (Zou et al., Science
// 326, 408 (2009)).
//
// Placement (place_chains): every chain is a self-avoiding random walk. The first bead
// is uniform in the region; each further bead sits at a bond length uniform in
// [d, d + l_max] from the previous one, in a direction uniform on the spherical cap of
// half-angle θ_max around the previous bond (uniform on the sphere for the first bond),
// so every turning angle is ≤ θ_max. A bead must lie wholly inside the region and keep a
// centre distance ≥ d (1 + clearance) from every bead but its bonded predecessor; a bead
// that fails `direction_tries` draws takes back its predecessor and grows again from the
// bead before (at most 4 N such backtracks), then the chain restarts; a chain that fails
// `max_attempts` restarts throws NoResultError (the region is too dense). Random numbers:
// std::mt19937_64 from the seed, converted to doubles by the top 53 bits, so a seed gives
// bit-identical placements on every platform.
//
// Fill (fill): the chains are placed loosely (at `insert_fraction` of the region's floor
// area × height) in the region raised as high as needed, dropped under gravity in a world
// with a cheap solver (settle_tolerance, settle_max_iterations) for at least the free-fall
// time of the insertion height and until the kinetic energy per bead falls below
// settle_kinetic_energy · m g d, or until it stops falling (the cheap solver's floor: a
// deep packing that 30 sweeps cannot hold up keeps jiggling at ~1e-2 m g d per bead;
// measured on 15 000 beads 20 d deep), then moved (positions and velocities; impulses are not
// carried) into a world with the caller's options and relaxed until the kinetic energy
// per bead falls below relax_kinetic_energy · m g d (or relax_max_steps). The kinetic
// energy here is that of translation, ½ m v²: the engine has no rolling or torsional
// resistance, so a bead spinning about its contact normals keeps its spin for ever
// (measured: a 144-bead fill keeps ½ I ω² ≈ 2e-4 m g d per bead indefinitely).
#pragma once

#include <cstdint>
#include <functional>
#include <variant>
#include <vector>

#include "shearzone/core/progress.hpp"
#include "shearzone/sim/world.hpp"

namespace shearzone::sim {

/// Axis-aligned box lo ≤ x ≤ hi.
struct BoxRegion {
  Vec3 lo = Vec3::Zero();
  Vec3 hi = Vec3::Ones();
};

/// Upright cylinder: inner_radius² ≤ (x − cx)² + (y − cy)² ≤ radius², z0 ≤ z ≤ z1 (an
/// annulus when inner_radius > 0: the cup around its vane).
struct CylinderRegion {
  double cx = 0.0, cy = 0.0;
  double radius = 1.0;
  double z0 = 0.0, z1 = 1.0;
  double inner_radius = 0.0;
  /// A wedge of it (0: the whole cylinder): azimuth in [sector_start, sector_start +
  /// 2π/sectors), the periodic sector of a world (Options::sectors). place_chains grows
  /// chains across its sides as in the whole cylinder and keeps each bead as its image
  /// inside the wedge, clear of every image of the others (and of its own).
  int sectors = 0;
  double sector_start = 0.0;
};

using Region = std::variant<BoxRegion, CylinderRegion>;

struct ChainOptions {
  int chains = 1;                ///< number of chains
  int beads_per_chain = 1;       ///< N (1: single beads, no ropes or angle rows)
  double diameter = 0.01;        ///< d (m)
  double density = 2500.0;       ///< (kg/m³)
  double l_max = 0.0;            ///< bond slack: bond length in [d, d + l_max] (m)
  double theta_max = 3.141592653589793;  ///< turning-angle limit (rad), (0, π]
  double clearance = 0.02;       ///< extra gap between non-bonded beads at placement, × d
  std::uint64_t seed = 1;        ///< std::mt19937_64 seed
  int max_attempts = 1000;       ///< restarts per chain before NoResultError
  int direction_tries = 64;      ///< draws per bead before the chain restarts
};

/// Bead centres chain by chain (bead k of chain c at index c·N + k) and chain ids.
struct ChainPlacement {
  std::vector<Vec3> positions;
  std::vector<int> chain_of_bead;
  int beads_per_chain = 1;
  std::int64_t restarts = 0;  ///< chain restarts needed in all
};

/// Throws ConfigError naming the option (`chains.<name>`) for an option out of range.
void validate(const ChainOptions& options);
/// Throws ConfigError for an empty or non-finite region.
void validate(const Region& region);

/// Random non-overlapping chains wholly inside `region` (see the file comment).
/// Throws ConfigError (options) or NoResultError (no room after max_attempts).
[[nodiscard]] ChainPlacement place_chains(const Region& region, const ChainOptions& options);

/// Adds the placed beads as mobile spheres and their chains (ropes of length d + l_max,
/// angle rows if θ_max < π) to `world`; returns the body index of every bead.
std::vector<int> add_chains(World& world, const ChainPlacement& placement,
                            const ChainOptions& options);

/// Adds the floor (z = lo.z) and the four side walls of a box as half-space walls.
void add_box_walls(World& world, const BoxRegion& box, double friction);

struct FillOptions {
  ChainOptions chains;
  /// Container interior. A box gets half-space walls (floor and sides, no lid); a
  /// cylinder needs the `container` callback of fill (e.g. a wall of fixed beads).
  Region region = BoxRegion{};
  double wall_friction = 0.5;          ///< μ of the box walls
  double insert_fraction = 0.2;        ///< bead volume / insertion volume when placed
  double settle_tolerance = 1e-2;      ///< NLGS tolerance of the drop
  int settle_max_iterations = 30;      ///< NLGS cap of the drop
  std::int64_t settle_max_steps = 20000;
  double settle_kinetic_energy = 1e-3;  ///< end of the drop: ½ m v² per bead / (m g d)
  double relax_kinetic_energy = 1e-5;   ///< end of the relaxation: ½ m v² per bead / (m g d)
  std::int64_t relax_max_steps = 20000;
  /// Terminal speed of the drop, × d per time step (0: none): after every drop step a
  /// bead faster than this is slowed to it, as in a viscous fluid, so a tall drop column
  /// cannot bring beads in at a diameter per step whatever the time step.
  double max_fall_speed = 0.1;
  /// End of the drop on its plateau: once the fall time has passed, the drop also ends
  /// when, twice in a row, the mean kinetic energy over a window of W steps
  /// (W = max(50, fall steps / 5)) is above plateau_ratio × the mean over the window
  /// before (it no longer falls; the relaxation's full solver takes it from there).
  /// 0: only settle_kinetic_energy.
  double plateau_ratio = 0.7;
  /// Told (steps done, steps expected) during the drop (expected: the fall time, or
  /// the steps done when the drop runs longer) and the relaxation (relax_max_steps).
  core::ProgressCallback drop_progress, relax_progress;
};

struct FillResult {
  World world;
  std::vector<int> beads;           ///< body index of every bead
  std::vector<int> chain_of_bead;   ///< chain id of every bead (same order)
  std::int64_t settle_steps = 0;
  std::int64_t relax_steps = 0;
  std::int64_t settle_cap_hits = 0;  ///< iteration-cap hits during the drop (expected)
  bool settle_plateau = false;       ///< the drop ended on its plateau, not on settle_kinetic_energy
  double kinetic_energy = 0.0;      ///< final ½ m v² per bead / (m g d)
  bool relaxed = false;             ///< relax_kinetic_energy reached
};

/// Throws ConfigError naming the option for an option out of range.
void validate(const FillOptions& options);

/// Builds a settled packing (see the file comment). `container` adds the container
/// (walls, fixed beads) to a fresh world; it is called twice (drop and relaxation
/// worlds) and must add the same bodies each time. Without it a box region gets
/// add_box_walls. Throws ConfigError, or NoResultError from placement or a diverging step.
[[nodiscard]] FillResult fill(const Options& world_options, const FillOptions& options,
                              const std::function<void(World&)>& container = {});

/// Volume of the intersection of a sphere with a region (m³), exact up to the
/// quadrature of the slice areas (closed-form disc ∩ rectangle / disc ∩ disc areas,
/// integrated over z by 8-point Gauss–Legendre on 16 panels between the kinks of the
/// slice area; relative error < 1e-10, checked against cap volumes in the tests). A
/// wedge (CylinderRegion::sectors) is refused (ConfigError).
[[nodiscard]] double sphere_region_volume(const Vec3& centre, double radius, const Region& region);

struct PackingMeasurement {
  double fraction = 0.0;      ///< Σ V(sphere ∩ region) / V(region), mobile spheres only
  double region_volume = 0.0;
  int spheres = 0;            ///< mobile spheres that intersect the region
};

/// Packing fraction of the mobile spheres of `world` inside `region` (not for a wedge:
/// ConfigError).
[[nodiscard]] PackingMeasurement packing_fraction(const World& world, const Region& region);

}  // namespace shearzone::sim
