// Cup geometry: circle fit and rim detection (docs/profile-width.md, "Geometry and calibration").
#include <cmath>
#include <random>

#include <catch2/catch.hpp>
#include <opencv2/imgproc.hpp>

#include "shearzone/core/error.hpp"
#include "shearzone/profile/geometry.hpp"

using namespace shearzone;

TEST_CASE("a circle is fitted exactly to points on it", "[profile]") {
  std::vector<cv::Point2d> pts;
  for (int k = 0; k < 12; ++k) {
    const double a = 0.3 + k * 0.25;  // an arc, not the full circle
    pts.emplace_back(512.3 + 301.7 * std::cos(a), 388.9 + 301.7 * std::sin(a));
  }
  const auto c = profile::fit_circle(pts);
  CHECK(c.centre_x_px == Approx(512.3).margin(1e-6));
  CHECK(c.centre_y_px == Approx(388.9).margin(1e-6));
  CHECK(c.radius_px == Approx(301.7).margin(1e-6));
  CHECK(c.rms_residual_px < 1e-6);
  CHECK_THROWS_AS(profile::fit_circle({{0, 0}, {1, 1}, {2, 2}}), NoResultError);
}

TEST_CASE("the cup rim is found in a frame to a fraction of a pixel", "[profile]") {
  // A bright ring (the rim) on a textured, noisy background.
  cv::Mat img(600, 800, CV_8U, cv::Scalar(40));
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> tex(0, 30);
  for (int i = 0; i < img.rows; ++i)
    for (int j = 0; j < img.cols; ++j) img.at<std::uint8_t>(i, j) = static_cast<std::uint8_t>(40 + tex(rng));
  const double cx = 410.4, cy = 297.6, r = 251.3;
  constexpr int kShift = 4;  // sub-pixel drawing
  cv::circle(img, cv::Point(static_cast<int>(std::lround(cx * 16)), static_cast<int>(std::lround(cy * 16))),
             static_cast<int>(std::lround(r * 16)), cv::Scalar(220), 3, cv::LINE_AA, kShift);
  const auto c = profile::detect_cup_circle(img, 200, 290);
  INFO("found (" << c.centre_x_px << ", " << c.centre_y_px << "), r " << c.radius_px << ", rms "
                 << c.rms_residual_px << ", " << c.edge_points << " edge px");
  // The anti-aliased 3 px line is found from its two edges; 0.5 px is well within the
  // scale of a PIV window and a bin (half a bead, ~17 px in the lab's films).
  constexpr double kTolPx = 0.5;
  CHECK(c.centre_x_px == Approx(cx).margin(kTolPx));
  CHECK(c.centre_y_px == Approx(cy).margin(kTolPx));
  CHECK(c.radius_px == Approx(r).margin(kTolPx));
  // No rim in range: a clear NoResultError.
  cv::Mat blank(600, 800, CV_8U, cv::Scalar(40));
  CHECK_THROWS_WITH(profile::detect_cup_circle(blank, 200, 290), Catch::Contains("no circle"));
}

TEST_CASE("metres per pixel from the cup radius", "[profile]") {
  CHECK(profile::m_per_px_from_radius(0.034, 500) == Approx(6.8e-5));
  CHECK_THROWS_AS(profile::m_per_px_from_radius(0, 500), ConfigError);
}
