// shearzone/sim/scenario.hpp: small scenes shared by the tests and benchmarks, so that
// "a pour into a box" is written once.
#pragma once

#include <cstdint>

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

}  // namespace shearzone::sim
