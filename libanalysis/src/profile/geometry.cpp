#include "shearzone/profile/geometry.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include <Eigen/Dense>
#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "shearzone/core/error.hpp"

namespace shearzone::profile {

CircleFit fit_circle(const std::vector<cv::Point2d>& pts) {
  if (pts.size() < 3)
    throw NoResultError(fmt::format("circle fit: {} points, at least 3 needed", pts.size()));
  // Kasa: x^2 + y^2 + D x + E y + F = 0, linear least squares (centred for conditioning).
  double mx = 0, my = 0;
  for (const auto& p : pts) {
    mx += p.x;
    my += p.y;
  }
  mx /= static_cast<double>(pts.size());
  my /= static_cast<double>(pts.size());
  const auto n = static_cast<Eigen::Index>(pts.size());
  Eigen::MatrixXd A(n, 3);
  Eigen::VectorXd b(n);
  for (Eigen::Index k = 0; k < n; ++k) {
    const double x = pts[static_cast<std::size_t>(k)].x - mx;
    const double y = pts[static_cast<std::size_t>(k)].y - my;
    A(k, 0) = x;
    A(k, 1) = y;
    A(k, 2) = 1;
    b(k) = -(x * x + y * y);
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeThinU | Eigen::ComputeThinV);
  if (svd.singularValues().size() != 3) throw NoResultError("circle fit: fewer than 3 points");
  const Eigen::Vector3d sv = svd.singularValues().head<3>();  // fixed size from here on
  if (sv(2) <= 1e-9 * sv(0))
    throw NoResultError("circle fit: the points are collinear (no circle)");
  Eigen::Vector3d s = svd.solve(b);
  double cx = -s(0) / 2, cy = -s(1) / 2;
  double r = std::sqrt(std::max(0.0, cx * cx + cy * cy - s(2)));
  // Gauss-Newton on the geometric distances d_k = |p_k - c| - r.
  for (int it = 0; it < 50; ++it) {
    Eigen::MatrixXd J(n, 3);
    Eigen::VectorXd res(n);
    for (Eigen::Index k = 0; k < n; ++k) {
      const double dx = pts[static_cast<std::size_t>(k)].x - mx - cx;
      const double dy = pts[static_cast<std::size_t>(k)].y - my - cy;
      const double d = std::max(1e-12, std::hypot(dx, dy));
      res(k) = d - r;
      J(k, 0) = -dx / d;
      J(k, 1) = -dy / d;
      J(k, 2) = -1;
    }
    const Eigen::Vector3d step = J.colPivHouseholderQr().solve(-res);
    cx += step(0);
    cy += step(1);
    r += step(2);
    if (step.norm() < 1e-10 * std::max(1.0, r)) break;
  }
  double ss = 0;
  for (const auto& p : pts) {
    const double d = std::hypot(p.x - mx - cx, p.y - my - cy) - r;
    ss += d * d;
  }
  CircleFit out;
  out.centre_x_px = cx + mx;
  out.centre_y_px = cy + my;
  out.radius_px = r;
  out.rms_residual_px = std::sqrt(ss / static_cast<double>(pts.size()));
  out.edge_points = static_cast<int>(pts.size());
  return out;
}

CircleFit detect_cup_circle(const cv::Mat& grey_in, double min_r, double max_r, double band_px) {
  if (grey_in.empty()) throw InputError("cup detection: empty frame");
  if (!(min_r > 0 && max_r > min_r))
    throw ConfigError(fmt::format("cup detection: radius range [{}, {}] px: expected 0 < min < max",
                                  min_r, max_r));
  cv::Mat grey;
  if (grey_in.depth() == CV_8U) grey = grey_in;
  else {
    double lo = 0, hi = 0;
    cv::minMaxLoc(grey_in, &lo, &hi);
    grey_in.convertTo(grey, CV_8U, hi > lo ? 255.0 / (hi - lo) : 1.0,
                      hi > lo ? -lo * 255.0 / (hi - lo) : 0.0);
  }
  cv::Mat blurred;
  cv::GaussianBlur(grey, blurred, cv::Size(0, 0), 2.0);
  std::vector<cv::Vec3f> circles;
  cv::HoughCircles(blurred, circles, cv::HOUGH_GRADIENT, 1.0, grey.rows, 100.0, 30.0,
                   static_cast<int>(std::floor(min_r)), static_cast<int>(std::ceil(max_r)));
  if (circles.empty())
    throw NoResultError(fmt::format("cup detection: no circle with a radius of {}-{} px in the frame "
                                    "(give --centre and --radii-px instead)",
                                    min_r, max_r));
  const cv::Vec3f c0 = circles.front();
  // Refinement along rays: on each of 720 rays through the Hough centre, the rim's
  // position to sub-pixel precision within +-band_px of the Hough radius: the
  // intensity extremum of a rim seen as a line (bright or dark), or the steepest
  // radial step of a rim seen as an edge, whichever stands out more.
  cv::Mat fimg;
  blurred.convertTo(fimg, CV_32F);
  auto sample = [&](double x, double y, double& out) {
    if (x < 0 || y < 0 || x > fimg.cols - 1.001 || y > fimg.rows - 1.001) return false;
    const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
    const double fx = x - x0, fy = y - y0;
    const float* r0 = fimg.ptr<float>(y0);
    const float* r1 = fimg.ptr<float>(y0 + 1);
    out = (1 - fy) * ((1 - fx) * r0[x0] + fx * r0[x0 + 1]) + fy * ((1 - fx) * r1[x0] + fx * r1[x0 + 1]);
    return true;
  };
  constexpr double kStep = 0.25;
  const int ns = static_cast<int>(2 * band_px / kStep) + 1;
  std::vector<cv::Point2d> pts;
  std::vector<double> prof(static_cast<std::size_t>(ns));
  for (int a = 0; a < 720; ++a) {
    const double th = a * std::numbers::pi / 360.0, ca = std::cos(th), sa = std::sin(th);
    bool inside = true;
    for (int k = 0; k < ns && inside; ++k) {
      const double r = c0[2] - band_px + k * kStep;
      inside = sample(c0[0] + r * ca, c0[1] + r * sa, prof[static_cast<std::size_t>(k)]);
    }
    if (!inside) continue;
    const double base = 0.5 * (prof.front() + prof.back());
    int kext = 0, kgrad = 1;
    double ext = 0, grad = 0;
    for (int k = 0; k < ns; ++k) {
      const double e = std::abs(prof[static_cast<std::size_t>(k)] - base);
      if (e > ext) {
        ext = e;
        kext = k;
      }
      if (k > 0 && k < ns - 1) {
        const double g = std::abs(prof[static_cast<std::size_t>(k + 1)] - prof[static_cast<std::size_t>(k - 1)]);
        if (g > grad) {
          grad = g;
          kgrad = k;
        }
      }
    }
    // A line peaks above both ends by more than a step's slope times ~2 px.
    const bool line = ext > grad / (2 * kStep) * 1.0;
    int k = line ? kext : kgrad;
    if (k <= 0 || k >= ns - 1) continue;
    auto val = [&](int i) {
      if (line) return std::abs(prof[static_cast<std::size_t>(i)] - base);
      return std::abs(prof[static_cast<std::size_t>(std::min(i + 1, ns - 1))] -
                      prof[static_cast<std::size_t>(std::max(i - 1, 0))]);
    };
    const double ym = val(k - 1), y0 = val(k), yp = val(k + 1);
    const double den = ym - 2 * y0 + yp;
    const double off = den < 0 ? 0.5 * (ym - yp) / den : 0.0;
    const double r = c0[2] - band_px + (k + std::clamp(off, -0.5, 0.5)) * kStep;
    pts.emplace_back(c0[0] + r * ca, c0[1] + r * sa);
  }
  if (pts.size() < 20)
    throw NoResultError(fmt::format("cup detection: the circle found at ({:.1f}, {:.1f}), r = {:.1f} "
                                    "px has only {} rim samples inside the frame; give --centre and "
                                    "--radii-px",
                                    c0[0], c0[1], c0[2], pts.size()));
  // One robust pass: drop samples farther than 3 RMS (clutter on a few rays).
  CircleFit c = fit_circle(pts);
  std::vector<cv::Point2d> keep;
  for (const auto& p : pts)
    if (std::abs(std::hypot(p.x - c.centre_x_px, p.y - c.centre_y_px) - c.radius_px) <=
        3 * c.rms_residual_px + 1e-9)
      keep.push_back(p);
  if (keep.size() >= 20 && keep.size() < pts.size()) c = fit_circle(keep);
  return c;
}

double m_per_px_from_radius(double R_m, double R_px) {
  if (!(std::isfinite(R_m) && R_m > 0 && std::isfinite(R_px) && R_px > 0))
    throw ConfigError(fmt::format("calibration: cup radius {} m over {} px: both must be positive",
                                  R_m, R_px));
  return R_m / R_px;
}

}  // namespace shearzone::profile
