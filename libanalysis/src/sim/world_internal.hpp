// Private to the contact-dynamics engine (world*.cpp): the helpers its stages share.
// Not installed.
#pragma once

#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/core/hash.hpp"
#include "shearzone/sim/world.hpp"

namespace shearzone::sim {
namespace {


inline bool finite(const Vec3& a) { return std::isfinite(a.x()) && std::isfinite(a.y()) && std::isfinite(a.z()); }

constexpr std::uint64_t kWallKeyBit = std::uint64_t{1} << 63;

constexpr std::uint64_t kImageKeyBit = std::uint64_t{1} << 31;

/// Body pair (i, j); a seam row (j seen as R x_j) sorts after i's plain rows.
inline std::uint64_t pair_key(int i, int j, int image = 0) {
  return (static_cast<std::uint64_t>(i) << 32) | (image != 0 ? kImageKeyBit : 0) | static_cast<std::uint64_t>(j);
}
inline std::uint64_t wall_key(int w, int j) {
  return kWallKeyBit | (static_cast<std::uint64_t>(w) << 32) | static_cast<std::uint64_t>(j);
}

/// Relative straight-chain guard on W_a: below it the angle row is
/// treated as inactive (sin θ ≈ 0, the constraint cannot bind within one step).
constexpr double kAngleGuard = 1e-12;


struct Fnv : core::Fnv1a {
  void v(const Vec3& a) {
    d(a.x());
    d(a.y());
    d(a.z());
  }
};

/// The row with the largest positive violation `excess(row)` (nullptr and 0 when none
/// exceeds 0): one search for the overlap, rope and angle checks of a step.
template <class Row, class Excess>
std::pair<double, const Row*> largest_excess(const std::vector<Row>& rows, Excess excess) {
  double worst = 0.0;
  const Row* at = nullptr;
  for (const Row& r : rows) {
    const double e = excess(r);
    if (e > worst) {
      worst = e;
      at = &r;
    }
  }
  return {worst, at};
}


/// Largest contact-search distance per step, in smallest bead diameters.
constexpr double kMaxAlertDiameters = 8.0;
constexpr double kRoundoffUlps = 64.0;  // see "Stopping test" in world.hpp

inline void check_drive(double phi0, double f_Hz, double phase, double t_start) {
  if (!std::isfinite(phi0) || !(f_Hz >= 0.0) || !std::isfinite(f_Hz) || !std::isfinite(phase) ||
      !std::isfinite(t_start))
    throw ConfigError(fmt::format("sim rotor: drive phi0 = {} rad, f = {} Hz, phase = {}, t_start = {} s: expected "
                                  "finite values, f >= 0",
                                  phi0, f_Hz, phase, t_start));
}

}  // namespace
}  // namespace shearzone::sim
