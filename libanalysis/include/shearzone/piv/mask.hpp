// shearzone/piv/mask.hpp: masks for PIV (CV_8U, 255 = masked, 0 = measured).
#pragma once

#include <opencv2/core.hpp>

#include "shearzone/core/vane.hpp"

namespace shearzone::piv {

/// Static mask of everything outside the annulus r_inner <= r <= r_outer about
/// (cx, cy): the cup wall outside, the vane hub inside. r_inner = 0 masks nothing
/// inside.
cv::Mat annulus_mask(cv::Size size, double cx, double cy, double r_inner_px, double r_outer_px);

/// The vane's footprint at angle `angle_rad` (blade 0, CCW on screen from +x), grown
/// by `margin_px` on every side: pixels whose centre lies on a blade are masked.
cv::Mat vane_mask(cv::Size size, double cx, double cy, double angle_rad,
                  const core::VaneGeometry& vane, double margin_px = 0.0);

/// Union of two masks (either may be empty).
cv::Mat combine_masks(const cv::Mat& a, const cv::Mat& b);

}  // namespace shearzone::piv
