// Private to the contact-dynamics engine (world.cpp): the solver's view of the bodies,
// its rows and the sweep bookkeeping. Not part of the installed API: world.hpp only
// forward-declares them.
#pragma once

#include <cstdint>
#include <vector>

#include "shearzone/sim/world.hpp"

namespace shearzone::sim::detail {

// Solver view of a body: one cache line (sentinel bodies after the real ones stand
// for the walls: zero velocity, zero inverse mass).
struct alignas(64) SolverBody {
  Vec3 v = Vec3::Zero();
  Vec3 w = Vec3::Zero();
  double inv_mass = 0.0;
  double inv_inertia = 0.0;
};
// Hot contact row, two cache lines; the freeze state sits in the first, so a skipped
// row costs one line. A wall row has i = a wall sentinel and ri = 0.
struct alignas(64) ContactRow {
  int i = 0, j = 0;
  std::int32_t frozen_until = 0;
  std::uint8_t quiet = 0;
  ContactStatus status = ContactStatus::open;
  Vec3 n = Vec3::UnitZ();  // from i (or the wall) to j
  double bias = 0.0;       // gap / h
  double ri = 0.0, rj = 0.0;
  double inv_wn = 0.0, inv_wt = 0.0;
  double mu = 0.0;
  double pn = 0.0;
  Vec3 pt = Vec3::Zero();
};
// Cold contact data, parallel to contacts_.
struct ContactInfo {
  std::uint64_t key = 0;
  int i = -1, wall = -1;  // i = −1 for a wall row
  double gap = 0.0;
};
struct PreviousContact {
  std::uint64_t key = 0;
  double pn = 0.0;
  Vec3 pt = Vec3::Zero();
  ContactStatus status = ContactStatus::open;
};
struct RopeRow {
  int i = 0, j = 0;
  double max_length = 0.0;
  Vec3 e = Vec3::UnitX();
  double c = 0.0, bias = 0.0, wb = 0.0, lambda = 0.0;
  std::int32_t frozen_until = 0;
  std::uint8_t quiet = 0;
};
struct AngleRow {
  int a = 0, b = 0, c = 0;
  double max_angle = 0.0, cos_max = 1.0;
  Vec3 ga = Vec3::Zero(), gb = Vec3::Zero(), gc = Vec3::Zero();  // ∂c/∂x
  double ca = 0.0, bias = 0.0, wa = 0.0, scale = 0.0, lambda = 0.0;
  std::int32_t frozen_until = 0;
  std::uint8_t quiet = 0;
  bool live = false;  // W_a above the straight-chain guard
};
// Rows of one slab (or of the boundary between slabs), by index.
struct RowLists {
  std::vector<int> contacts, ropes, angles;
  void clear() {
    contacts.clear();
    ropes.clear();
    angles.clear();
  }
};
struct SweepTotals {
  double dv2 = 0.0, wp2 = 0.0;
  std::int64_t updates = 0, active = 0, skipped = 0, changed = 0;
};

}  // namespace shearzone::sim::detail
