// shearzone/core/conventions.hpp: the coordinate, sign and unit conventions, written
// once. Every output file's header (CSV `# key: value` lines, HDF5 attributes)
// carries these strings, and the README quotes them.
//
// Image axes: the pixel in row i, column j has its centre at (x, y) = (j, i);
// x points right, y points down. Displacements run from frame A to frame B.
//
// Rotation: positive is counter-clockwise as the camera sees the image. With a
// centre (x_c, y_c), r = |(x - x_c, y - y_c)|:
//     v_theta = (u (y - y_c) - v (x - x_c)) / r
//     v_r     = (u (x - x_c) + v (y - y_c)) / r
// A solid rotation with omega > 0 is u = omega (y - y_c), v = -omega (x - x_c),
// which has v_theta = omega r > 0 and v_r = 0.
//
// Worked example: centre (10, 10), point (13, 10) (3 px right of the centre),
// omega = 0.1 rad per frame: u = 0, v = -0.3 px (upwards on screen), v_theta = 0.3.
#pragma once

#include <cmath>
#include <string>
#include <utility>
#include <vector>

namespace shearzone::core {

/// One line each, used verbatim in output headers.
inline constexpr const char* kConventionImageAxes =
    "pixel (row i, column j) has its centre at (x, y) = (j, i); x right, y down; "
    "displacements run from frame A to frame B";
inline constexpr const char* kConventionRotation =
    "positive rotation is counter-clockwise as the camera sees it; "
    "v_theta = (u*(y-yc) - v*(x-xc))/r, v_r = (u*(x-xc) + v*(y-yc))/r; "
    "solid rotation omega>0: u = omega*(y-yc), v = -omega*(x-xc)";
inline constexpr const char* kConventionUnits =
    "SI inside the library; every CSV column name carries its unit (_px, _m, _s, _rad, ...)";

/// Key/value pairs that go into every output header, in this order.
inline std::vector<std::pair<std::string, std::string>> convention_metadata() {
  return {{"convention_image_axes", kConventionImageAxes},
          {"convention_rotation", kConventionRotation},
          {"convention_units", kConventionUnits}};
}

/// Polar components of a velocity (or displacement) about a centre.
struct PolarComponents {
  double v_r = 0.0;      ///< radial, positive outwards
  double v_theta = 0.0;  ///< azimuthal, positive counter-clockwise as the camera sees it
};

/// Polar decomposition of (u, v) at (x, y) about (xc, yc), with the project's sign
/// convention. At the centre itself (r = 0) both components are 0.
inline PolarComponents polar_from_cartesian(double x, double y, double u, double v, double xc,
                                            double yc) {
  const double dx = x - xc, dy = y - yc;
  const double r = std::hypot(dx, dy);
  if (r == 0.0) return {};
  return {(u * dx + v * dy) / r, (u * dy - v * dx) / r};
}

/// Cartesian (u, v) of a purely azimuthal velocity v_theta at (x, y) about (xc, yc):
/// the inverse of polar_from_cartesian for v_r = 0.
inline std::pair<double, double> cartesian_from_azimuthal(double x, double y, double v_theta,
                                                          double xc, double yc) {
  const double dx = x - xc, dy = y - yc;
  const double r = std::hypot(dx, dy);
  if (r == 0.0) return {0.0, 0.0};
  return {v_theta * dy / r, -v_theta * dx / r};
}

/// Unit vector in image coordinates of the direction at angle `angle_rad`, measured
/// counter-clockwise as the camera sees it from the +x axis: (cos a, -sin a).
inline std::pair<double, double> image_direction(double angle_rad) {
  return {std::cos(angle_rad), -std::sin(angle_rad)};
}

}  // namespace shearzone::core
