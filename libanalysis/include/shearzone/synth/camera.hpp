// shearzone/synth/camera.hpp: a camera looking straight down a cup's axis, projecting
// world points (metres) to image pixels.
//
// World: right-handed, +z up, the cup's axis through (axis_x_m, axis_y_m). Image: the
// project's convention (core/conventions.hpp): pixel centres at integers, x to the
// right along world +X, y downwards along world -Y, so a rotation counter-clockwise
// seen from above is counter-clockwise on the image. The axis images at
// (centre_x_px, centre_y_px).
//
// Two projections:
//   orthographic: x = cx + (X - ax) / m_per_px, y = cy - (Y - ay) / m_per_px;
//   pinhole:      a pinhole on the axis at height_m above the reference plane z_ref_m,
//                 focal length f = height_m / m_per_px (px), so that
//                 x = cx + f (X - ax) / (z_ref + height - Z), likewise y;
//                 the scale is m_per_px exactly on the plane z = z_ref (the bead
//                 surface) and (z_ref + height - Z) / f at any other height.
#pragma once

#include <string>

namespace shearzone::synth {

struct DownCamera {
  bool orthographic = false;
  int width_px = 1280, height_px = 720;
  double centre_x_px = 639.5, centre_y_px = 359.5;
  double axis_x_m = 0.0, axis_y_m = 0.0;
  double m_per_px = 1e-4;   ///< scale on the reference plane
  double z_ref_m = 0.0;     ///< the reference plane (pinhole)
  double height_m = 0.5;    ///< the pinhole above the reference plane

  /// Throws ConfigError naming the bad value.
  void validate() const;
  /// Focal length in px (pinhole); 0 for orthographic.
  [[nodiscard]] double focal_px() const { return orthographic ? 0.0 : height_m / m_per_px; }
  /// px per m at height z (orthographic: 1 / m_per_px everywhere). Points at or above
  /// the pinhole have none: callers keep z below z_ref + height.
  [[nodiscard]] double px_per_m(double z) const {
    return orthographic ? 1.0 / m_per_px : focal_px() / (z_ref_m + height_m - z);
  }
  /// Image of the world point (X, Y, Z).
  void project(double X, double Y, double Z, double& x_px, double& y_px) const {
    const double s = px_per_m(Z);
    x_px = centre_x_px + s * (X - axis_x_m);
    y_px = centre_y_px - s * (Y - axis_y_m);
  }
  /// "pinhole" or "orthographic".
  [[nodiscard]] std::string projection_name() const { return orthographic ? "orthographic" : "pinhole"; }
};

}  // namespace shearzone::synth
