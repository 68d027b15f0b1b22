// shearzone/piv/deform.hpp: image deformation for multipass PIV.
//
// Symmetric deformation (second-order accurate in time): with a dense displacement
// D(x) from A to B, the deformed frames are
//     A'(x) = A(x - D(x)/2),   B'(x) = B(x + D(x)/2),
// so that a pattern at x in the mid-time frame sits at the same place in A' and B'
// and the correlation of A' and B' measures the residual displacement.
#pragma once

#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "shearzone/piv/options.hpp"

namespace shearzone::piv {

/// Interpolates a field given on a regular grid (values[ny][nx] at x0 + j*step,
/// y0 + i*step; CV_32F) to every pixel of `size` (bilinear between grid points,
/// constant beyond the outermost ones). Returns CV_32F.
cv::Mat grid_to_pixels(const cv::Mat& values, double x0, double y0, double step, cv::Size size);

/// Samples `image` (CV_32F) at (map_x, map_y) with `method`, at the exact positions
/// (no 1/32 px rounding as in cv::remap); positions outside the image take the value
/// at the nearest border point. The B-spline methods (Unser 1999, "Splines: a
/// perfect fit for signal and image processing") interpolate the pixel values
/// exactly and have a flatter pass band than Keys' cubic convolution.
cv::Mat remap_image(const cv::Mat& image, const cv::Mat& map_x, const cv::Mat& map_y,
                    Interpolation method);

/// What remap_coefficients() samples: the B-spline coefficients for kBSpline and
/// kBSpline5, the image itself otherwise. Compute once per image, reuse per pass.
cv::Mat interpolation_coefficients(const cv::Mat& image, Interpolation method);
/// The same into caller-owned buffers (reused when their size fits): `out` must not
/// share memory with `image`; `scratch` is working space.
void interpolation_coefficients(const cv::Mat& image, Interpolation method, cv::Mat& out,
                                cv::Mat& scratch);

/// remap_image() on precomputed interpolation_coefficients().
cv::Mat remap_coefficients(const cv::Mat& coefficients, const cv::Mat& map_x, const cv::Mat& map_y,
                           Interpolation method);

/// Per image row, the pixel spans [from, to) a pass reads (sorted, disjoint).
using RowSpans = std::vector<std::vector<std::pair<int, int>>>;

/// Symmetric deformation in one sweep: with D the bilinear interpolant of the grid
/// field (grid_u, grid_v at x0 + j*step, y0 + i*step; constant beyond), writes
/// a_out(x) = A(x - D(x)/2) and b_out(x) = B(x + D(x)/2), sampling the
/// interpolation_coefficients() of A and B with `method`. With `spans`, only those
/// pixels (and up to 7 neighbours in a row) are written; the rest keep what they held.
/// A pixel's value does not depend on the spans.
void deform_pair(const cv::Mat& coef_a, const cv::Mat& coef_b, const cv::Mat& grid_u,
                 const cv::Mat& grid_v, double x0, double y0, double step, Interpolation method,
                 cv::Mat& a_out, cv::Mat& b_out, const RowSpans* spans = nullptr);

/// B-spline coefficients (degree 3 or 5) of an image: the prefilter along rows and
/// columns with mirror boundaries. Exposed for tests.
cv::Mat bspline_coefficients(const cv::Mat& image, int degree);
void bspline_coefficients(const cv::Mat& image, int degree, cv::Mat& out, cv::Mat& scratch);

}  // namespace shearzone::piv
