// shearzone/sim/scenario.hpp: small scenes shared by the tests and benchmarks, so that
// "a pour into a box" is written once.
#pragma once

#include <cstdint>
#include <functional>

#include "shearzone/sim/world.hpp"

namespace shearzone::sim {

/// Beads dropped into a square box of five planes (floor at z = 0 and four sides, no
/// lid), centred on the z axis. Beads are placed in layers of per_row x per_row on a
/// square lattice, each coordinate in x and y jittered uniformly (std::mt19937_64 with
/// `seed`, std::uniform_real_distribution), layer k at height (z0 + layer_dz k) d.
struct BoxPour {
  int beads = 60;
  int per_row = 4;               ///< beads along a row of a layer
  double diameter = 0.01;        ///< d (m)
  double density = 7800.0;       ///< kg/m³
  double half_width = 0.05;      ///< box half-width (m): sides at ±half_width
  double wall_friction = 0.3;    ///< μ of the five planes
  double pitch = 1.2;            ///< lattice spacing (× d)
  double jitter = 0.05;          ///< half-width of the x, y jitter (× d)
  double z0 = 1.0;               ///< height of the first layer's centres (× d)
  double layer_dz = 1.2;         ///< spacing of the layers (× d)
  std::uint64_t seed = 7;
};

/// Adds the box's planes and the beads of `pour` to `world` (planes first).
void add_box_pour(World& world, const BoxPour& pour);

/// `count` beads on a staggered lattice in a square box sized for them (the packing of
/// `shearzone bench sim`). With n = max(2, ⌈∛count⌉) and pitch a = pitch·d, layer k
/// (centres at z = 0.6 d + k a) holds n × n beads at (a/2 + i a, a/2 + j a) when k is
/// even and (n−1) × (n−1) beads shifted by a/2 when k is odd; each bead's x and y are
/// jittered by ±jitter·d (std::mt19937_64 with `seed`, 53-bit uniform). Walls of fixed
/// planes (add_box_walls) enclose [0, n a]² × [0, top + d].
struct LatticePour {
  int count = 100;
  double diameter = 2e-3;        ///< d (m)
  double density = 2500.0;       ///< kg/m³
  double pitch = 1.2;            ///< lattice spacing (× d)
  double jitter = 0.1;           ///< half-width of the x, y jitter (× d)
  double wall_friction = 0.3;    ///< μ of the box planes
  std::uint64_t seed = 1;
};
struct LatticePourLayout {
  int floor_side = 0;  ///< n: beads along a floor edge
  int layers = 0;      ///< layers placed
  double top = 0.0;    ///< top of the highest layer's beads (m)
};
/// Adds the beads, then the walls, of `pour` to `world`.
LatticePourLayout add_lattice_pour(World& world, const LatticePour& pour);

/// How a lattice pour becomes a packing at rest: dropped with a cheap solver until the
/// translational ½ m v² per bead falls below drop_kinetic_energy m g d (after at least
/// the free fall of the lattice's gaps plus one d, at most drop_max_steps), then relaxed
/// with the solver to be measured (the cheap drop leaves the beads jiggling: its
/// unconverged steps act like elasticity) for at least relax_min_steps until a step
/// converges (no iteration cap hit) with ½ m v² per bead < relax_kinetic_energy m g d
/// (at most relax_max_steps).
struct PourSettling {
  double drop_time_step = 5e-4;
  double drop_tolerance = 1e-2;
  int drop_max_iterations = 30;
  double drop_kinetic_energy = 1e-3;
  std::int64_t drop_max_steps = 20000;
  std::int64_t relax_min_steps = 0, relax_max_steps = 20000;
  double relax_kinetic_energy = 1e-5;
};
struct SettledPour {
  WorldState state;  ///< relaxed, with the relaxation's options; step 0, no cap hits
  LatticePourLayout layout;
  std::int64_t drop_steps = 0, relax_steps = 0;
  double drop_kinetic_energy = 0.0, relax_kinetic_energy = 0.0;  ///< at their ends, ½ m v² per bead / (m g d)
  double height = 0.0;  ///< top of the highest bead after the drop (m)
};
/// `pour` dropped (default Options but for the drop's solver and the friction
/// pour.wall_friction, beads and walls) and relaxed as `settling` says, with the solver
/// that `relax_solver` sets on the drop's options (at_time_step carries the impulses over).
SettledPour settle_lattice_pour(const LatticePour& pour, const PourSettling& settling,
                                const std::function<void(Options&)>& relax_solver);

}  // namespace shearzone::sim
