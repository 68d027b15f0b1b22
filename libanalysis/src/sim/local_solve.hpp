// Private to the contact-dynamics engine (world.cpp; unit-tested in
// tests/sim/test_local_solve.cpp): the exact per-contact Signorini–Coulomb solve for
// spheres (the contact model of docs/sim.md, "The model").
//
// For a sphere–sphere or sphere–plane contact the 3×3 Delassus block is diagonal in
// the contact frame, W = diag(W_n, W_t, W_t), so the local problem with all other
// impulses frozen has a closed form:
//   P_n* = −(u⁰_n + g/h)/W_n,   P_t* = −u⁰_t/W_t      (u⁰: velocity without this row)
//   P_n* ≤ 0            → open:     P = 0
//   |P_t*| ≤ μ P_n*     → sticking: P = P*
//   otherwise           → sliding:  P_n = P_n*, P_t = μ P_n P_t*/|P_t*|   (radial return)
// The friction impulse never changes P_n (no CCP convexification). The gap term g/h is
// the θ = 1 Moreau–Jean form of g + h u_n⁺ ≥ 0 (it also pushes out an existing overlap).
#pragma once

#include <cmath>

#include "shearzone/sim/world.hpp"

namespace shearzone::sim {

struct LocalContactResult {
  double normal_impulse = 0.0;  ///< P_n ≥ 0 (N s)
  Vec3 tangential_impulse = Vec3::Zero();  ///< P_t ⊥ n (N s)
  ContactStatus status = ContactStatus::kOpen;
};

/// Solves one contact exactly. `u0n`, `u0t`: normal and tangential relative velocity
/// of the contact point without this row's impulse (u0t ⊥ n); `gap_over_h`: g/h;
/// `wn`, `wt` > 0: diagonal Delassus entries; `mu` ≥ 0: friction coefficient.
inline LocalContactResult solve_sphere_contact(double u0n, const Vec3& u0t, double gap_over_h,
                                               double wn, double wt, double mu) {
  LocalContactResult r;
  const double pn = -(u0n + gap_over_h) / wn;
  if (!(pn > 0.0)) return r;
  r.normal_impulse = pn;
  r.tangential_impulse = -u0t / wt;
  const double pt = r.tangential_impulse.norm();
  const double limit = mu * pn;
  if (pt <= limit) {
    r.status = ContactStatus::kSticking;
  } else {
    r.tangential_impulse *= limit / pt;
    r.status = ContactStatus::kSliding;
  }
  return r;
}

}  // namespace shearzone::sim
