#include <omp.h>

#include <cmath>

#include <catch2/catch.hpp>
#include <opencv2/imgproc.hpp>

#include "shearzone/core/conventions.hpp"
#include "shearzone/core/error.hpp"
#include "shearzone/synth/generator.hpp"

using namespace shearzone;
using namespace shearzone::synth;
using Catch::Matchers::Contains;

namespace {
SynthOptions particle_pair(FieldKind kind) {
  SynthOptions o;
  o.texture = TextureKind::kParticles;
  o.field.kind = kind;
  o.image.seed = 12345;
  return o;
}

cv::Mat as_double(const cv::Mat& m) {
  cv::Mat d;
  m.convertTo(d, CV_64F);
  return d;
}
}  // namespace

TEST_CASE("default synth options are valid", "[synth]") {
  CHECK_NOTHROW(SynthOptions{}.validate());
  SynthOptions beads;
  beads.texture = TextureKind::kBeads;
  CHECK_NOTHROW(beads.validate());
}

TEST_CASE("invalid synth options name the option and the rule", "[synth]") {
  SynthOptions o;
  o.particles.density_ppp = 0.5;
  CHECK_THROWS_WITH(o.validate(), Contains("ParticleOptions::density_ppp = 0.5") &&
                                      Contains("0 < density_ppp <= 0.2"));
  o = SynthOptions{};
  o.image.bit_depth = 12;
  CHECK_THROWS_WITH(o.validate(), Contains("ImageOptions::bit_depth = 12: must be 8 or 16"));
  CHECK_THROWS_WITH(field_kind_from_name("rotaton"),
                    Contains("unknown field \"rotaton\"; expected one of: uniform, rotation, "
                             "shear-zone"));
}

// cv::phaseCorrelate was to recover a uniform (2.3, -1.7) shift to 0.02 px. OpenCV
// 4.6's phaseCorrelate locates the peak with a 5x5 weighted centroid of the
// phase-correlation surface, which is a Dirichlet kernel for a sub-pixel shift; the
// centroid pulls it towards the integer shift (measured on this pair: (2.108, -1.895)
// with a Hann window, (2.125, -1.875) without; docs/synth.md, "Known limits"). So
// phaseCorrelate checks the integer part here, and the sub-pixel part is checked to
// 0.02 px with an independent estimator: OpenCV's normalised cross-correlation
// (matchTemplate) and a 3-point Gaussian peak fit (measured error 0.0015 px).
TEST_CASE("a uniform pair carries the requested shift", "[synth]") {
  constexpr double kShiftTolPx = 0.02;
  struct Shift {
    double u, v;
  };
  for (Shift s : {Shift{2.3, -1.7}, Shift{0.35, 0.2}, Shift{-3.9, 1.1}}) {
    SynthOptions o = particle_pair(FieldKind::kUniform);
    o.field.u_px = s.u;
    o.field.v_px = s.v;
    FrameGenerator gen(o);
    cv::Mat a, b;
    gen.next().convertTo(a, CV_32F);
    gen.next().convertTo(b, CV_32F);
    INFO("requested shift (" << s.u << ", " << s.v << ")");

    // Integer part: cv::phaseCorrelate.
    cv::Mat window;
    cv::createHanningWindow(window, a.size(), CV_32F);
    const cv::Point2d pc = cv::phaseCorrelate(a, b, window);
    INFO("phaseCorrelate: (" << pc.x << ", " << pc.y << ")");
    CHECK(std::lround(pc.x) == std::lround(s.u));
    CHECK(std::lround(pc.y) == std::lround(s.v));

    // Sub-pixel: normalised cross-correlation of the central 256x256 block of A over
    // B, with a 3-point Gaussian fit around the integer peak in x and y.
    const int m = 8;
    const cv::Rect templ(128, 128, 256, 256);
    cv::Mat r;
    cv::matchTemplate(b(cv::Rect(128 - m, 128 - m, 256 + 2 * m, 256 + 2 * m)), a(templ), r,
                      cv::TM_CCOEFF_NORMED);
    cv::Point p;
    cv::minMaxLoc(r, nullptr, nullptr, nullptr, &p);
    REQUIRE(p.x > 0);
    REQUIRE(p.y > 0);
    REQUIRE(p.x < r.cols - 1);
    REQUIRE(p.y < r.rows - 1);
    auto gauss3 = [](double lo, double c, double hi) {
      lo = std::log(lo);
      c = std::log(c);
      hi = std::log(hi);
      return (lo - hi) / (2.0 * (lo - 2.0 * c + hi));
    };
    const double dx = p.x - m + gauss3(r.at<float>(p.y, p.x - 1), r.at<float>(p.y, p.x),
                                       r.at<float>(p.y, p.x + 1));
    const double dy = p.y - m + gauss3(r.at<float>(p.y - 1, p.x), r.at<float>(p.y, p.x),
                                       r.at<float>(p.y + 1, p.x));
    INFO("cross-correlation + Gaussian fit: (" << dx << ", " << dy << ")");
    CHECK(std::abs(dx - s.u) < kShiftTolPx);
    CHECK(std::abs(dy - s.v) < kShiftTolPx);
  }
}

// The particle count found from local maxima at 0.005 particles per pixel is
// within 3 sigma of the request (sigma = sqrt(N): the count in a region is Poisson).
TEST_CASE("the particle count from local maxima matches the requested density", "[synth]") {
  SynthOptions o = particle_pair(FieldKind::kUniform);
  o.particles.density_ppp = 0.005;
  FrameGenerator gen(o);
  const cv::Mat img = gen.next();
  cv::Mat dilated;
  cv::dilate(img, dilated, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3)));
  // Count maxima away from the border (a particle centred just outside the image
  // would put a maximum on the edge).
  const int border = 5;
  const std::uint8_t threshold = static_cast<std::uint8_t>(0.25 * 255);  // peaks are >= 0.6
  int count = 0;
  for (int i = border; i < img.rows - border; ++i)
    for (int j = border; j < img.cols - border; ++j) {
      const std::uint8_t v = img.at<std::uint8_t>(i, j);
      if (v >= threshold && v == dilated.at<std::uint8_t>(i, j)) {
        // Plateaus of equal maxima count once: skip if an earlier neighbour ties.
        bool earlier_tie = false;
        for (int di = -1; di <= 0 && !earlier_tie; ++di)
          for (int dj = -1; dj <= 1; ++dj) {
            if (di == 0 && dj >= 0) break;
            if (img.at<std::uint8_t>(i + di, j + dj) == v) earlier_tie = true;
          }
        if (!earlier_tie) ++count;
      }
    }
  const double requested = 0.005 * (img.rows - 2 * border) * (img.cols - 2 * border);
  INFO("found " << count << " maxima, requested " << requested);
  CHECK(std::abs(count - requested) < 3.0 * std::sqrt(requested));
}

// A rotation pair's truth has the sign of the convention.
TEST_CASE("a rotation pair turns counter-clockwise on screen for omega > 0", "[synth]") {
  SynthOptions o = particle_pair(FieldKind::kRotation);
  o.field.omega_rad = 0.02;
  FrameGenerator gen(o);
  const double xc = gen.options().field.centre_x_px, yc = gen.options().field.centre_y_px;
  SECTION("truth") {
    for (const auto& p : gen.truth(32, 1.0)) {
      const auto pc = core::polar_from_cartesian(p.x_px, p.y_px, p.u_px, p.v_px, xc, yc);
      const double r = std::hypot(p.x_px - xc, p.y_px - yc);
      CHECK(pc.v_theta == Approx(0.02 * r).margin(1e-12));
      CHECK(pc.v_r == Approx(0.0).margin(1e-12));
      if (p.x_px > xc + 50 && std::abs(p.y_px - yc) < 20) CHECK(p.v_px < 0);  // right side moves up
    }
  }
  SECTION("images") {
    // A patch right of the centre moves up (v < 0), one left of it moves down.
    const cv::Mat a = as_double(gen.next()), b = as_double(gen.next());
    const cv::Rect right(static_cast<int>(xc) + 150, static_cast<int>(yc) - 32, 64, 64);
    const cv::Rect left(static_cast<int>(xc) - 150 - 64, static_cast<int>(yc) - 32, 64, 64);
    const cv::Point2d sr = cv::phaseCorrelate(a(right), b(right));
    const cv::Point2d sl = cv::phaseCorrelate(a(left), b(left));
    // Expected |v| = omega * r = 0.02 * ~182 px = 3.6 px.
    CHECK(sr.y < -2.5);
    CHECK(sl.y > 2.5);
  }
}

TEST_CASE("tracers are placed symmetrically about the midpoint", "[synth]") {
  for (FieldKind kind : {FieldKind::kUniform, FieldKind::kRotation, FieldKind::kShearZone}) {
    SynthOptions o = particle_pair(kind);
    o.field.u_px = 1.7;
    o.field.omega_rad = 0.03;
    o.sequence.frames = 4;
    o.sequence.oscillate_f_Hz = 2.0;
    FrameGenerator gen(o);
    DisplacementField field(gen.options().field);
    for (int k = 0; k + 1 < o.sequence.frames; ++k) {
      const auto xa = gen.tracer_x(), ya = gen.tracer_y();
      gen.next_ideal();
      const auto& xb = gen.tracer_x();
      const auto& yb = gen.tracer_y();
      const double s = gen.frame_time(k).pair_scale;
      double worst = 0;
      for (std::size_t i = 0; i < xa.size(); i += 97) {
        if (std::abs(xb[i] - xa[i]) > 100) continue;  // wrapped in the periodic domain
        const auto d = field(0.5 * (xa[i] + xb[i]), 0.5 * (ya[i] + yb[i]));
        worst = std::max({worst, std::abs(xb[i] - xa[i] - s * d[0]),
                          std::abs(yb[i] - ya[i] - s * d[1])});
      }
      INFO("field " << field_kind_name(kind) << ", pair " << k);
      CHECK(worst < 1e-9);  // the iteration tolerance is 1e-12 px
    }
  }
}

TEST_CASE("rotation keeps every tracer's radius over a long sequence", "[synth]") {
  SynthOptions o = particle_pair(FieldKind::kShearZone);
  o.sequence.frames = 60;
  o.image.width_px = o.image.height_px = 64;
  FrameGenerator gen(o);
  const double xc = gen.options().field.centre_x_px, yc = gen.options().field.centre_y_px;
  std::vector<double> r0;
  for (std::size_t i = 0; i < gen.num_tracers(); ++i)
    r0.push_back(std::hypot(gen.tracer_x()[i] - xc, gen.tracer_y()[i] - yc));
  while (!gen.done()) gen.next_ideal();
  double worst = 0;
  for (std::size_t i = 0; i < gen.num_tracers(); ++i)
    worst = std::max(worst, std::abs(std::hypot(gen.tracer_x()[i] - xc, gen.tracer_y()[i] - yc) - r0[i]));
  CHECK(worst < 1e-9);
}

TEST_CASE("frames are bit-identical for 1 and 2 threads", "[synth]") {
  for (TextureKind texture : {TextureKind::kParticles, TextureKind::kBeads}) {
    SynthOptions o = particle_pair(FieldKind::kShearZone);
    o.texture = texture;
    o.image.width_px = 200;
    o.image.height_px = 150;
    o.vane.blades = 4;
    std::vector<cv::Mat> frames[2];
    for (int threads : {1, 2}) {
      omp_set_num_threads(threads);
      FrameGenerator gen(o);
      while (!gen.done()) frames[threads - 1].push_back(gen.next());
    }
    omp_set_num_threads(omp_get_num_procs());
    for (std::size_t k = 0; k < frames[0].size(); ++k)
      CHECK(cv::norm(frames[0][k], frames[1][k], cv::NORM_INF) == 0.0);
  }
}

TEST_CASE("the vane follows phi(t) = phi0 sin(2 pi f t)", "[synth]") {
  SynthOptions o = particle_pair(FieldKind::kRotation);
  o.sequence.frames = 10;
  o.sequence.fps = 25;
  o.sequence.oscillate_f_Hz = 2.5;
  o.vane.phi0_rad = 0.4;
  FrameGenerator gen(o);
  for (int k = 0; k < 10; ++k) {
    const auto ft = gen.frame_time(k);
    CHECK(ft.t_s == Approx(k / 25.0));
    CHECK(ft.phi_rad == Approx(0.4 * std::sin(2 * M_PI * 2.5 * k / 25.0)).margin(1e-15));
    CHECK(ft.pair_scale == Approx(std::cos(2 * M_PI * 2.5 * (k + 0.5) / 25.0)).margin(1e-15));
  }
}

TEST_CASE("a field too steep for the midpoint rule is a ConfigError", "[synth]") {
  SynthOptions o = particle_pair(FieldKind::kRotation);
  o.field.omega_rad = 3.0;  // |grad d| = 3 per frame
  o.sequence.frames = 3;
  o.image.width_px = o.image.height_px = 32;
  FrameGenerator gen(o);
  CHECK_THROWS_WITH(gen.next_ideal(), Contains("too fast in space"));
}
