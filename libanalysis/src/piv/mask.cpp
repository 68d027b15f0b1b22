#include "shearzone/piv/mask.hpp"

#include <algorithm>
#include <cmath>

#include "shearzone/core/check.hpp"

namespace shearzone::piv {

cv::Mat annulus_mask(cv::Size size, double cx, double cy, double r_inner_px, double r_outer_px) {
  cv::Mat m(size, CV_8U);
  for (int i = 0; i < size.height; ++i) {
    std::uint8_t* row = m.ptr<std::uint8_t>(i);
    for (int j = 0; j < size.width; ++j) {
      const double r = std::hypot(j - cx, i - cy);
      row[j] = (r < r_inner_px || r > r_outer_px) ? 255 : 0;
    }
  }
  return m;
}

cv::Mat vane_mask(cv::Size size, double cx, double cy, double angle_rad,
                  const core::VaneGeometry& vane, double margin_px) {
  core::VaneGeometry g = vane;
  g.half_width_px += margin_px;
  g.radius_px += margin_px;
  cv::Mat m = cv::Mat::zeros(size, CV_8U);
  if (g.blades <= 0) return m;
  const int i0 = std::max(0, static_cast<int>(std::floor(cy - g.radius_px)));
  const int i1 = std::min(size.height - 1, static_cast<int>(std::ceil(cy + g.radius_px)));
  const int j0 = std::max(0, static_cast<int>(std::floor(cx - g.radius_px)));
  const int j1 = std::min(size.width - 1, static_cast<int>(std::ceil(cx + g.radius_px)));
  for (int i = i0; i <= i1; ++i) {
    std::uint8_t* row = m.ptr<std::uint8_t>(i);
    for (int j = j0; j <= j1; ++j) row[j] = g.contains(j, i, cx, cy, angle_rad) ? 255 : 0;
  }
  return m;
}

cv::Mat combine_masks(const cv::Mat& a, const cv::Mat& b) {
  if (a.empty()) return b;
  if (b.empty()) return a;
  SHEARZONE_CHECK(a.size() == b.size() && a.type() == CV_8U && b.type() == CV_8U);
  cv::Mat m;
  cv::bitwise_or(a, b, m);
  return m;
}

}  // namespace shearzone::piv
