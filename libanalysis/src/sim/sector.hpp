// Private to the sim module: the geometry of a periodic sector (Options::sectors), shared
// by the engine (world*.cpp) and the builder (builder.cpp), which includes this header
// alone, not the engine's rows (solver_rows.hpp).
#pragma once

#include "shearzone/sim/world.hpp"

namespace shearzone::sim::detail {

// The rotation of a periodic sector (Options::sectors) about its vertical axis: R^k for
// k in −1..1 (any k for place()). Exact for k = 4 (cos = 0, sin = 1).
struct Sector {
  bool on = false;
  double c = 1.0, s = 0.0;  // cos, sin of the wedge angle
  double cx = 0.0, cy = 0.0;
  double start = 0.0, width = 0.0;  // azimuth of the first side, wedge angle (rad)
  double nx = 0.0, ny = 0.0;        // inward unit normal of the first side
  explicit Sector(const Options& o);
  /// R^k v (a velocity, an impulse), k in −1..1.
  [[nodiscard]] Vec3 rot(const Vec3& v, int k) const {
    if (k == 0) return v;
    const double sk = k > 0 ? s : -s;
    return {c * v.x() - sk * v.y(), sk * v.x() + c * v.y(), v.z()};
  }
  /// R^k v for any k (one wedge turn at a time).
  [[nodiscard]] Vec3 turn(Vec3 v, int k) const {
    for (; k > 0; --k) v = rot(v, 1);
    for (; k < 0; ++k) v = rot(v, -1);
    return v;
  }
  /// The image of a point: centre + R^k (x − centre), any k.
  [[nodiscard]] Vec3 place(const Vec3& x, int k) const {
    const Vec3 p = turn(Vec3(x.x() - cx, x.y() - cy, x.z()), k);
    return {p.x() + cx, p.y() + cy, p.z()};
  }
  /// Distance of x from the first side's plane (positive inside).
  [[nodiscard]] double first_side(const Vec3& x) const { return nx * (x.x() - cx) + ny * (x.y() - cy); }
  /// Whole wedges between x's azimuth and the wedge (0 inside; on the axis: 0).
  [[nodiscard]] int wedges(const Vec3& x) const;
};
}  // namespace shearzone::sim::detail
