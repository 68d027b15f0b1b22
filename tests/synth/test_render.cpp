#include <cmath>
#include <numbers>
#include <random>

#include <catch2/catch.hpp>

#include "shearzone/synth/render.hpp"

using namespace shearzone::synth;

namespace {
struct Moments {
  double sum = 0, cx = 0, cy = 0;
};
Moments moments(const cv::Mat& img, double scale) {
  Moments m;
  for (int i = 0; i < img.rows; ++i)
    for (int j = 0; j < img.cols; ++j) {
      const double v =
          (img.depth() == CV_64F ? img.at<double>(i, j) : img.at<std::uint16_t>(i, j)) / scale;
      m.sum += v;
      m.cx += v * j;
      m.cy += v * i;
    }
  m.cx /= m.sum;
  m.cy /= m.sum;
  return m;
}
}  // namespace

// docs/synth.md: an isolated particle's centroid is within 0.01 px of its set position
// and its summed intensity matches the Gaussian integral to 1e-3. Checked on the stored
// 16-bit image (noise off), so pixel integration, cut-off and quantisation all count.
TEST_CASE("an isolated particle's centroid and summed intensity match the set values",
          "[synth]") {
  constexpr double kCentroidTolPx = 0.01;
  constexpr double kSumRelTol = 1e-3;
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> frac(0.0, 1.0);
  // d >= 2 px: below that the pixel-integrated centroid itself is biased towards the
  // pixel centre by up to exp(-2 pi^2 sigma^2)/pi (0.02 px at d = 1.5 px): the
  // peak-locking of under-sampled particles, a property of sampling, not of the renderer.
  for (double d : {2.0, 3.0, 5.0}) {
    for (int trial = 0; trial < 10; ++trial) {
      const double x = 20 + frac(rng), y = 21 + frac(rng), peak = 0.5 + 0.4 * frac(rng);
      const cv::Mat ideal = render_particles({x}, {y}, {peak}, cv::Size(41, 43), d);
      const cv::Mat stored = quantise(ideal, 0.0, 0.0, 16, 1, 0);
      const Moments m = moments(stored, 65535.0);
      INFO("d = " << d << ", position (" << x << ", " << y << ")");
      CHECK(std::abs(m.cx - x) < kCentroidTolPx);
      CHECK(std::abs(m.cy - y) < kCentroidTolPx);
      const double sigma = d / 4.0;
      const double integral = peak * 2.0 * std::numbers::pi * sigma * sigma;
      CHECK(std::abs(m.sum / integral - 1.0) < kSumRelTol);
    }
  }
}

TEST_CASE("a particle's e^-2 diameter is the set diameter", "[synth]") {
  // Large particle so that pixel integration barely blurs the profile.
  const double d = 20.0;
  const cv::Mat img = render_particles({50.0}, {50.0}, {1.0}, cv::Size(101, 101), d);
  const double centre = img.at<double>(50, 50);
  const double at_radius = img.at<double>(50, 60);  // d/2 = 10 px from the centre
  CHECK(at_radius / centre == Approx(std::exp(-2.0)).epsilon(0.01));
}

TEST_CASE("quantise is the same for any thread count and seeded per frame", "[synth]") {
  cv::Mat ideal(64, 64, CV_64F, cv::Scalar(0.5));
  const cv::Mat a = quantise(ideal, 0.0, 0.05, 8, 7, 3);
  const cv::Mat b = quantise(ideal, 0.0, 0.05, 8, 7, 3);
  const cv::Mat c = quantise(ideal, 0.0, 0.05, 8, 7, 4);
  CHECK(cv::norm(a, b, cv::NORM_INF) == 0.0);
  CHECK(cv::norm(a, c, cv::NORM_INF) > 0.0);
  cv::Scalar mean, sd;
  cv::meanStdDev(a, mean, sd);
  // 4096 samples: the sample std of N(0, 0.05*255) is within 5 % with near certainty.
  CHECK(sd[0] == Approx(0.05 * 255).epsilon(0.05));
  CHECK(mean[0] == Approx(127.5).margin(1.0));
}

TEST_CASE("quantise clips to the full scale", "[synth]") {
  cv::Mat ideal(4, 4, CV_64F, cv::Scalar(3.0));
  ideal.at<double>(0, 0) = -1.0;
  const cv::Mat q = quantise(ideal, 0.0, 0.0, 16, 1, 0);
  CHECK(q.at<std::uint16_t>(0, 0) == 0);
  CHECK(q.at<std::uint16_t>(1, 1) == 65535);
}

TEST_CASE("vane blades point counter-clockwise from +x as the camera sees it", "[synth]") {
  const double cx = 50, cy = 50;
  // phi = 0: blade 0 along +x.
  CHECK(inside_vane(80, 50, cx, cy, 0.0, 4, 3, 40));
  CHECK_FALSE(inside_vane(80, 60, cx, cy, 0.0, 4, 3, 40));
  // phi = pi/4: blade 0 points up-right on screen (x larger, y smaller).
  CHECK(inside_vane(50 + 20, 50 - 20, cx, cy, std::numbers::pi / 4, 1, 3, 40));
  CHECK_FALSE(inside_vane(50 + 20, 50 + 20, cx, cy, std::numbers::pi / 4, 1, 3, 40));
  // Beyond the blade radius nothing is covered.
  CHECK_FALSE(inside_vane(95, 50, cx, cy, 0.0, 4, 3, 40));

  cv::Mat img(101, 101, CV_64F, cv::Scalar(1.0));
  draw_vane(img, cx, cy, 0.0, 4, 3, 40, 0.2);
  CHECK(img.at<double>(50, 80) == Approx(0.2));    // on blade 0
  CHECK(img.at<double>(20, 50) == Approx(0.2));    // blade 1 points up (-y)
  CHECK(img.at<double>(20, 20) == Approx(1.0));    // between blades
  CHECK(img.at<double>(53, 80) > 0.2);             // the blade edge is anti-aliased
  CHECK(img.at<double>(53, 80) < 1.0);
}

TEST_CASE("a bead is lit from the light direction and the gaps stay dark", "[synth]") {
  BeadShading sh;  // light from the upper left (azimuth 135 deg)
  const cv::Mat img = render_beads({30.0}, {30.0}, {0.0}, {1.0}, cv::Size(61, 61), 30.0, sh);
  cv::Point hi;
  cv::minMaxLoc(img, nullptr, nullptr, nullptr, &hi);
  CHECK(hi.x < 30);  // highlight left of centre
  CHECK(hi.y < 30);  // and above it (y down)
  CHECK(img.at<double>(0, 0) == Approx(sh.gap_level));
}
