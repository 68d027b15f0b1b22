// Shared scene builders for the sim tests.
#pragma once

#include <cmath>
#include <numbers>

#include "shearzone/core/error.hpp"
#include "shearzone/sim/world.hpp"

namespace testutil {

inline constexpr double kD = 0.01;      ///< bead diameter (m)
inline constexpr double kRho = 2500.0;  ///< glass (kg/m³)
inline constexpr double kG = 9.81;      ///< (m/s²)

inline double deg(double a) { return a * std::numbers::pi / 180.0; }

/// The engine's solver variants, each test that validates the solver runs all of them.
enum class Solver { alternate, forward, anderson };
/// NLGS alternating or forward sweeps; anderson: forward sweeps with Anderson(3).
inline void set_solver(shearzone::sim::Options& o, Solver s) {
  o.alternate_sweeps = s == Solver::alternate;
  o.anderson_depth = s == Solver::anderson ? 3 : 0;
}

/// `o` with solver `s`'s sweeps.
inline shearzone::sim::Options solver_options(Solver s, shearzone::sim::Options o) {
  set_solver(o, s);
  return o;
}

inline bool rel_close(double a, double b, double tol) { return std::abs(a - b) <= tol * std::abs(b); }

/// Three fixed beads touching each other in an equilateral triangle at z = 0 (indices
/// 0..2); returns the height of a bead of diameter kD resting in the pocket above them.
inline double add_pocket(shearzone::sim::World& w) {
  using shearzone::sim::Vec3;
  const double rc = kD / std::sqrt(3.0);  // centroid to vertex for side kD
  for (int k = 0; k < 3; ++k) {
    const double a = 2.0 * std::numbers::pi * k / 3.0;
    w.add_sphere(Vec3(rc * std::cos(a), rc * std::sin(a), 0.0), kD, kRho,
                 shearzone::sim::BodyKind::kFixed);
  }
  return std::sqrt(kD * kD - rc * rc);
}

/// Vertical impulse (N s) that all fixed bodies and walls gave mobile bodies in the last step.
inline double vertical_impulse_from_supports(const shearzone::sim::World& w) {
  using shearzone::sim::BodyKind;
  double sum = 0.0;
  for (const auto& c : w.contacts()) {
    const shearzone::sim::Vec3 p = c.normal_impulse * c.normal + c.tangential_impulse;
    const bool i_support = c.body_i < 0 || w.kind(c.body_i) != BodyKind::kMobile;
    const bool j_support = w.kind(c.body_j) != BodyKind::kMobile;
    if (i_support && !j_support) sum += p.z();
    if (j_support && !i_support) sum -= p.z();
  }
  return sum;
}

}  // namespace testutil
