#include <random>

#include <catch2/catch.hpp>
#include <opencv2/imgproc.hpp>

#include "shearzone/core/error.hpp"
#include "shearzone/piv/preprocess.hpp"

using namespace shearzone;

TEST_CASE("default preprocessing options are valid and do nothing", "[piv]") {
  piv::PreprocessOptions o;
  CHECK_NOTHROW(o.validate());
  CHECK_FALSE(o.any());
  cv::Mat img(16, 16, CV_8U, cv::Scalar(51));
  const cv::Mat out = piv::preprocess(img, o);
  CHECK(out.type() == CV_32F);
  CHECK(out.at<float>(3, 3) == Approx(0.2f));
}

TEST_CASE("the temporal median removes what does not move", "[piv]") {
  std::vector<cv::Mat> frames;
  for (int k = 0; k < 5; ++k) {
    cv::Mat f(20, 20, CV_8U, cv::Scalar(100));   // static background
    f.at<std::uint8_t>(10, 2 + 3 * k) = 255;      // a moving bright pixel
    frames.push_back(f);
  }
  const cv::Mat bg = piv::temporal_median(frames);
  CHECK(bg.at<float>(10, 5) == Approx(100.0f / 255.0f));
  piv::PreprocessOptions o;
  o.background = true;
  const cv::Mat out = piv::preprocess(frames[1], o, bg);
  CHECK(out.at<float>(10, 5) == Approx((255.0f - 100.0f) / 255.0f).epsilon(1e-5));
  CHECK(out.at<float>(0, 0) == 0.0f);
}

TEST_CASE("intensity capping, CLAHE and high-pass do what they say", "[piv]") {
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> u(40, 80);
  cv::Mat img(64, 64, CV_8U);
  for (int i = 0; i < 64; ++i)
    for (int j = 0; j < 64; ++j) img.at<std::uint8_t>(i, j) = static_cast<std::uint8_t>(u(rng) + 2 * j);
  img.at<std::uint8_t>(30, 30) = 255;  // a glint
  SECTION("capping lowers the glint, not the rest") {
    piv::PreprocessOptions o;
    o.intensity_cap = 2.0;
    const cv::Mat out = piv::preprocess(img, o);
    CHECK(out.at<float>(30, 30) < 250.0f / 255.0f);
    CHECK(out.at<float>(5, 5) == Approx(img.at<std::uint8_t>(5, 5) / 255.0f));
  }
  SECTION("CLAHE stretches the local contrast") {
    piv::PreprocessOptions o;
    o.clahe = true;
    o.clahe_tile_px = 16;
    // A dull image: grey levels 100..110 only.
    std::uniform_int_distribution<int> dull(100, 110);
    cv::Mat low(64, 64, CV_8U);
    for (int i = 0; i < 64; ++i)
      for (int j = 0; j < 64; ++j) low.at<std::uint8_t>(i, j) = static_cast<std::uint8_t>(dull(rng));
    const cv::Rect patch(24, 24, 16, 16);
    cv::Scalar m0, s0, m1, s1;
    cv::meanStdDev(piv::preprocess(low, {})(patch), m0, s0);
    cv::meanStdDev(piv::preprocess(low, o)(patch), m1, s1);
    INFO("patch std before " << s0[0] << ", after " << s1[0]);
    CHECK(s1[0] > 1.5 * s0[0]);  // clip limit 2 bounds the stretch near 2x (measured 1.9x)
  }
  SECTION("high-pass removes the left-to-right ramp") {
    piv::PreprocessOptions o;
    o.highpass_sigma_px = 4.0;
    const cv::Mat out = piv::preprocess(img, o);
    const double left = cv::mean(out(cv::Rect(8, 8, 12, 48)))[0];
    const double right = cv::mean(out(cv::Rect(44, 8, 12, 48)))[0];
    CHECK(std::abs(left - right) < 0.02);
  }
  SECTION("bad options are ConfigErrors") {
    piv::PreprocessOptions o;
    o.clahe = true;
    o.clahe_tile_px = 2;
    CHECK_THROWS_AS(o.validate(), ConfigError);
  }
}
