// shearzone/profile/geometry.hpp: the cup seen from above, and the pixel scale.
//
// The cup is a circle of inner radius R about the cup centre (x_c, y_c) in image
// pixels (the project's image convention: pixel (row i, column j) centred at
// (x, y) = (j, i), y down). The vane turns about the same axis; its blades reach
// R_v. Profiles run over R_v <= r <= R.
#pragma once

#include <opencv2/core.hpp>

namespace shearzone::profile {

struct CircleFit {
  double centre_x_px = 0, centre_y_px = 0, radius_px = 0;
  double rms_residual_px = 0;  ///< RMS distance of the edge points from the circle
  int edge_points = 0;         ///< edge pixels used by the least-squares refinement
};

/// Finds the cup rim in a grey frame: cv::HoughCircles (gradient method) for the
/// strongest circle with radius in [min_radius_px, max_radius_px], then a
/// least-squares (geometric, Gauss-Newton) fit of a circle to the Canny edge pixels
/// within `band_px` of it. Throws NoResultError ("no circle ...") when Hough finds
/// none or fewer than 20 edge pixels support it.
CircleFit detect_cup_circle(const cv::Mat& grey, double min_radius_px, double max_radius_px,
                            double band_px = 6.0);

/// Least-squares circle through points (x_k, y_k): algebraic (Kasa) start, then
/// Gauss-Newton on the geometric distances. Throws NoResultError for fewer than 3
/// points or collinear points.
CircleFit fit_circle(const std::vector<cv::Point2d>& points);

/// Metres per pixel from the cup's inner radius known in metres and seen in pixels.
/// Throws ConfigError unless both are positive and finite.
double m_per_px_from_radius(double R_m, double R_px);

}  // namespace shearzone::profile
