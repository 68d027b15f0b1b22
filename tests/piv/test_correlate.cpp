#include <cmath>
#include <random>

#include <catch2/catch.hpp>

#include "shearzone/piv/correlate.hpp"

using namespace shearzone::piv;

namespace {
/// Fills a W x W window from a larger seeded random texture, offset by (ox, oy).
void texture_window(float* dst, int w, int ox, int oy) {
  static const std::vector<float> tex = [] {
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<float> t(128 * 128);
    for (auto& v : t) v = u(rng);
    return t;
  }();
  for (int y = 0; y < w; ++y)
    for (int x = 0; x < w; ++x) dst[y * w + x] = tex[(y + oy + 32) * 128 + (x + ox + 32)];
}
}  // namespace

// Float FFTs of 32x32 windows: the normalised peak of identical windows is 1 to
// within single-precision rounding.
constexpr double kFloatTol = 1e-4;

TEST_CASE("identical windows correlate to a peak of 1 at zero displacement", "[piv]") {
  Correlator c(32);
  Workspace ws(32);
  texture_window(ws.a(), 32, 0, 0);
  texture_window(ws.b(), 32, 0, 0);
  REQUIRE(c.correlate(ws));
  const Peak p = find_peak(ws.corr(), 32, 15, Subpixel::kGauss3);
  REQUIRE(p.found);
  CHECK(p.height == Approx(1.0).margin(kFloatTol));
  CHECK(p.dx == Approx(0.0).margin(kFloatTol));
  CHECK(p.dy == Approx(0.0).margin(kFloatTol));
  CHECK(p.ratio > 2.0f);
}

TEST_CASE("an integer shift of the pattern from A to B is the peak position", "[piv]") {
  Correlator c(32);
  Workspace ws(32);
  // B shows the texture shifted by (+3, -2): B(x) = T(x - (3, -2)).
  texture_window(ws.a(), 32, 0, 0);
  texture_window(ws.b(), 32, -3, 2);
  REQUIRE(c.correlate(ws));
  const Peak p = find_peak(ws.corr(), 32, 15, Subpixel::kGauss3);
  CHECK(std::lround(p.dx) == 3);
  CHECK(std::lround(p.dy) == -2);
  CHECK(p.height > 0.5f);
}

TEST_CASE("a window without variance does not correlate", "[piv]") {
  Correlator c(16);
  Workspace ws(16);
  std::fill(ws.a(), ws.a() + 256, 0.7f);
  texture_window(ws.b(), 16, 0, 0);
  CHECK_FALSE(c.correlate(ws));
  for (int i = 0; i < 256; ++i) REQUIRE(ws.corr()[i] == 0.0f);
}

TEST_CASE("the 3-point Gaussian fit is exact on a sampled Gaussian", "[piv]") {
  for (double x0 : {-0.45, -0.2, 0.0, 0.13, 0.49}) {
    auto g = [x0](double x) { return std::exp(-(x - x0) * (x - x0) / 1.3); };
    CHECK(gauss3(g(-1), g(0), g(1)) == Approx(x0).margin(1e-12));
  }
  // Non-positive neighbours fall back to a parabola and stay within [-1, 1].
  CHECK(std::abs(gauss3(-0.1, 1.0, 0.5)) <= 1.0);
}

TEST_CASE("the 2-D Gaussian fit is exact on a sampled elliptic Gaussian", "[piv]") {
  // Tilted Gaussian peak at (0.3, -0.2) on a 16x16 plane centred at (8, 8).
  const int w = 16;
  std::vector<float> plane(w * w);
  for (int y = 0; y < w; ++y)
    for (int x = 0; x < w; ++x) {
      const double dx = x - 8 - 0.3, dy = y - 8 + 0.2;
      plane[y * w + x] = static_cast<float>(std::exp(-(1.2 * dx * dx + 0.5 * dx * dy + 0.9 * dy * dy)));
    }
  const Peak p2 = find_peak(plane.data(), w, 7, Subpixel::kGauss2D);
  CHECK(p2.dx == Approx(0.3).margin(1e-5));  // float samples
  CHECK(p2.dy == Approx(-0.2).margin(1e-5));
  // The separable 3-point fit is biased by the tilt; the 2-D fit is not.
  const Peak p1 = find_peak(plane.data(), w, 7, Subpixel::kGauss3);
  CHECK(std::abs(p1.dx - 0.3) > 1e-3);
}

TEST_CASE("the peak ratio compares the highest peak with the next local maximum", "[piv]") {
  const int w = 16;
  std::vector<float> plane(w * w, 0.0f);
  plane[8 * w + 8] = 0.9f;
  plane[8 * w + 9] = 0.5f;   // inside the 5x5: ignored
  plane[2 * w + 3] = 0.3f;   // the second peak
  const Peak p = find_peak(plane.data(), w, 7, Subpixel::kGauss3);
  CHECK(p.height == Approx(0.9f));
  CHECK(p.ratio == Approx(3.0f));
  // A search radius of 2 leaves the second peak outside the search square.
  CHECK(find_peak(plane.data(), w, 2, Subpixel::kGauss3).ratio == 1000.0f);
  std::vector<float> flat(w * w, -0.1f);
  CHECK_FALSE(find_peak(flat.data(), w, 7, Subpixel::kGauss3).found);
}

TEST_CASE("the shoulder of a broad peak is not a second peak", "[piv]") {
  // A wide Gaussian peak (as from 20 px beads): its flanks outside 5x5 stay high but
  // are not local maxima, so the ratio compares with the small bump only.
  const int w = 32;
  std::vector<float> plane(w * w);
  for (int y = 0; y < w; ++y)
    for (int x = 0; x < w; ++x) {
      const double r2 = (x - 16.0) * (x - 16.0) + (y - 16.0) * (y - 16.0);
      plane[y * w + x] = static_cast<float>(std::exp(-r2 / 50.0));
    }
  plane[4 * w + 4] += 0.2f;  // a small separate bump far out
  const Peak p = find_peak(plane.data(), w, 15, Subpixel::kGauss3);
  CHECK(p.ratio > 4.0f);
}

// A smooth blob (a bead-sized Gaussian) shifted by a sub-pixel amount: the correlation
// peak of two 32 px windows returns part of the shift (the window's edge pulls it towards
// zero), the gradient step the whole of it.
TEST_CASE("the gradient step returns a bead's sub-pixel shift that the peak reads low", "[piv]") {
  constexpr int kW = 32;
  constexpr double kShiftX = 0.4, kShiftY = -0.3;
  constexpr double kSigma = 6.0;  // a bead of about 28 px
  auto blob = [&](float* dst, double sx, double sy) {
    for (int y = 0; y < kW; ++y)
      for (int x = 0; x < kW; ++x) {
        double v = 0;
        for (const auto& c : {std::pair{1.0, 11.0}, std::pair{30.0, 20.0}, std::pair{14.0, 1.0}, std::pair{17.0, 30.0}})
          v += std::exp(-(std::pow(x - c.first - sx, 2) + std::pow(y - c.second - sy, 2)) / (2 * kSigma * kSigma));
        dst[y * kW + x] = static_cast<float>(v);
      }
  };
  Correlator c(kW);
  Workspace ws(kW);
  blob(ws.a(), -0.5 * kShiftX, -0.5 * kShiftY);
  blob(ws.b(), 0.5 * kShiftX, 0.5 * kShiftY);
  REQUIRE(c.correlate(ws));
  const Peak p = find_peak(ws.corr(), kW, 8, Subpixel::kGauss3);
  const GradientStep g = gradient_step(ws.a(), ws.b(), kW);
  REQUIRE(g.ok);
  INFO("peak (" << p.dx << ", " << p.dy << "), sigma " << p.sigma_px << "; gradient (" << g.dx << ", " << g.dy
                << "), conditioning " << g.conditioning);
  CHECK(p.sigma_px > 2.0f);
  CHECK(std::abs(p.dx) < 0.8 * kShiftX);  // the peak's pull towards zero (edges cut the blobs)
  CHECK(std::abs(p.dy) < 0.8 * std::abs(kShiftY));
  // Gradient step: the symmetric difference leaves O(d^3 / sigma^2); 2 % of the shift.
  constexpr double kGradientRelTol = 0.02;
  CHECK(g.dx == Approx(kShiftX).epsilon(kGradientRelTol));
  CHECK(g.dy == Approx(kShiftY).epsilon(kGradientRelTol));
}

TEST_CASE("the gradient step refuses a window without texture", "[piv]") {
  Workspace ws(16);
  std::fill(ws.a(), ws.a() + 256, 0.0f);
  std::fill(ws.b(), ws.b() + 256, 0.0f);
  CHECK_FALSE(gradient_step(ws.a(), ws.b(), 16).ok);
}
