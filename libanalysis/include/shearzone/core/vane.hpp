// shearzone/core/vane.hpp: the geometry of a blade vane seen from above.
//
// `blades` straight blades of half-width `half_width_px` run from the centre out to
// `radius_px`; blade k points along the direction at angle a + 2 pi k / blades,
// measured counter-clockwise as the camera sees it from +x (image direction
// (cos a, -sin a), y down). Used by the synthetic renderer (to draw the vane) and by
// PIV (to mask it), so both agree on the footprint.
#pragma once

#include <cmath>
#include <numbers>

namespace shearzone::core {

struct VaneGeometry {
  int blades = 4;              ///< number of blades (0: no vane)
  double half_width_px = 4.0;  ///< blade half-width, px
  double radius_px = 60.0;     ///< blade radius (tip distance from the centre), px

  /// True if (x, y) lies on a blade when the vane centre is (cx, cy) and blade 0
  /// points at angle `angle_rad`. A blade is the rectangle from half_width behind
  /// the centre to radius along its direction, half_width either side; points beyond
  /// radius from the centre are outside.
  bool contains(double x, double y, double cx, double cy, double angle_rad) const {
    const double dx = x - cx, dy = y - cy;
    if (dx * dx + dy * dy > radius_px * radius_px) return false;
    for (int k = 0; k < blades; ++k) {
      const double a = angle_rad + 2.0 * std::numbers::pi * k / blades;
      const double ex = std::cos(a), ey = -std::sin(a);
      const double along = dx * ex + dy * ey;
      const double across = -dx * ey + dy * ex;
      if (along >= -half_width_px && along <= radius_px && std::abs(across) <= half_width_px)
        return true;
    }
    return false;
  }
};

}  // namespace shearzone::core
