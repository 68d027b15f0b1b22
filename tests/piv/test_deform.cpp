#include <cmath>
#include <numbers>

#include <catch2/catch.hpp>

#include "shearzone/piv/deform.hpp"

using namespace shearzone::piv;

namespace {
cv::Mat sinusoid(cv::Size size, double shift_x, double shift_y) {
  cv::Mat m(size, CV_32F);
  for (int i = 0; i < size.height; ++i)
    for (int j = 0; j < size.width; ++j)
      m.at<float>(i, j) = static_cast<float>(
          0.5 + 0.25 * std::sin(2 * std::numbers::pi * (j - shift_x) / 9.0) *
                    std::cos(2 * std::numbers::pi * (i - shift_y) / 11.0));
  return m;
}

void identity_maps(cv::Size size, double dx, double dy, cv::Mat& mx, cv::Mat& my) {
  mx.create(size, CV_32F);
  my.create(size, CV_32F);
  for (int i = 0; i < size.height; ++i)
    for (int j = 0; j < size.width; ++j) {
      mx.at<float>(i, j) = static_cast<float>(j + dx);
      my.at<float>(i, j) = static_cast<float>(i + dy);
    }
}
}  // namespace

TEST_CASE("every interpolator reproduces the pixels at integer positions", "[piv]") {
  const cv::Mat img = sinusoid({40, 30}, 0, 0);
  cv::Mat mx, my;
  identity_maps(img.size(), 0, 0, mx, my);
  for (auto m : {Interpolation::kBilinear, Interpolation::kBicubic, Interpolation::kBSpline,
                 Interpolation::kBSpline5}) {
    const cv::Mat out = remap_image(img, mx, my, m);
    INFO(interpolation_name(m));
    CHECK(cv::norm(out, img, cv::NORM_INF) < 1e-5);  // float prefilter round-off
  }
}

TEST_CASE("higher-order interpolators shift a smooth pattern more accurately", "[piv]") {
  // Sample at (x + 0.37, y - 0.21): the result should be the pattern moved by
  // (-0.37, +0.21). Compare inside a 6 px border.
  const cv::Size size(80, 60);
  const cv::Mat img = sinusoid(size, 0, 0);
  const cv::Mat want = sinusoid(size, -0.37, 0.21);
  cv::Mat mx, my;
  identity_maps(size, 0.37, -0.21, mx, my);
  const cv::Rect inner(6, 6, size.width - 12, size.height - 12);
  double err[4];
  int k = 0;
  for (auto m : {Interpolation::kBilinear, Interpolation::kBicubic, Interpolation::kBSpline,
                 Interpolation::kBSpline5}) {
    const cv::Mat out = remap_image(img, mx, my, m);
    err[k++] = cv::norm(out(inner), want(inner), cv::NORM_INF);
  }
  INFO("max error: bilinear " << err[0] << ", bicubic " << err[1] << ", bspline " << err[2]
                              << ", bspline5 " << err[3]);
  CHECK(err[1] < err[0]);
  CHECK(err[2] < err[1]);
  CHECK(err[3] < err[2]);
  CHECK(err[3] < 2e-3);  // quintic on a 9 px period: ~1e-3 of a 0.25 amplitude
}

TEST_CASE("grid_to_pixels interpolates bilinearly and holds values beyond the grid",
          "[piv]") {
  cv::Mat g = (cv::Mat_<float>(2, 2) << 0.0f, 1.0f, 2.0f, 3.0f);  // nodes at x = 5, 13; y = 5, 13
  const cv::Mat d = grid_to_pixels(g, 5, 5, 8, cv::Size(20, 20));
  CHECK(d.at<float>(5, 5) == Approx(0.0f));
  CHECK(d.at<float>(5, 9) == Approx(0.5f));
  CHECK(d.at<float>(9, 9) == Approx(1.5f));
  CHECK(d.at<float>(0, 0) == Approx(0.0f));    // before the first node
  CHECK(d.at<float>(19, 19) == Approx(3.0f));  // after the last node
}

TEST_CASE("deforming only some spans of rows gives those pixels bit for bit", "[piv]") {
  // PIV deforms only the pixels of unmasked windows: a pixel's value must not depend on
  // which other pixels are asked for (the SIMD blocks are counted from the row start).
  const cv::Size size(203, 61);  // a row of 25 whole blocks of 8 and a partial one
  const cv::Mat a = sinusoid(size, 0, 0), b = sinusoid(size, 1.3, -0.7);
  cv::Mat gu(5, 9, CV_32F), gv(5, 9, CV_32F);
  for (int i = 0; i < gu.rows; ++i)
    for (int j = 0; j < gu.cols; ++j) {
      gu.at<float>(i, j) = static_cast<float>(1.3 + 0.21 * j - 0.1 * i);
      gv.at<float>(i, j) = static_cast<float>(-0.7 + 0.05 * i * j);
    }
  for (auto m : {Interpolation::kBilinear, Interpolation::kBSpline5}) {
    const cv::Mat ca = interpolation_coefficients(a, m), cb = interpolation_coefficients(b, m);
    cv::Mat fa, fb;
    deform_pair(ca, cb, gu, gv, 7.5, 7.5, 16.0, m, fa, fb);
    RowSpans spans(static_cast<std::size_t>(size.height));
    for (int i = 0; i < size.height; i += 2) spans[static_cast<std::size_t>(i)] = {{3, 17}, {40, 41}, {190, 203}};
    cv::Mat sa(size, CV_32F, cv::Scalar(-1)), sb(size, CV_32F, cv::Scalar(-1));
    deform_pair(ca, cb, gu, gv, 7.5, 7.5, 16.0, m, sa, sb, &spans);
    for (int i = 0; i < size.height; ++i)
      for (int j = 0; j < size.width; ++j) {
        bool inside = false;
        for (const auto& [from, to] : spans[static_cast<std::size_t>(i)]) inside |= j >= from && j < to;
        if (!inside) {
          // Untouched unless inside a block of 8 that holds a span's pixel.
          if (i % 2) REQUIRE(sa.at<float>(i, j) == -1.0f);
          continue;
        }
        REQUIRE(sa.at<float>(i, j) == fa.at<float>(i, j));
        REQUIRE(sb.at<float>(i, j) == fb.at<float>(i, j));
      }
  }
}
