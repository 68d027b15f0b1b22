// The cup as the lab camera films it (synth/cup_view.hpp): a bead appears where the
// pinhole and orthographic formulas say, the rim drawn is the circle --detect-cup finds,
// and a rigid rotation of the packing filmed and measured by PIV gives v = omega r.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <catch2/catch.hpp>
#include <opencv2/core.hpp>

#include "shearzone/core/unset.hpp"
#include "shearzone/core/vector_field.hpp"
#include "shearzone/piv/piv.hpp"
#include "shearzone/profile/geometry.hpp"
#include "shearzone/synth/cup_view.hpp"
#include "shearzone/synth/render.hpp"

using namespace shearzone;

namespace {

/// The data-samples cup: radius 24 mm, 4 mm beads, a four-blade vane of radius 10 mm.
synth::CupGeometry small_cup() {
  return {.bead_diameter_m = 0.004, .radius_m = 0.024, .height_m = 0.02, .vane_blades = 4, .vane_radius_m = 0.01,
          .vane_height_m = 0.02};
}

/// A hexagonal layer of beads at height z in the annulus between the vane and the wall,
/// over a floor layer one diameter below, turned by `angle` about the axis.
synth::CupBeads packing(const synth::CupGeometry& c, double z, double angle) {
  synth::CupBeads f;
  const double d = c.bead_diameter_m, a = 1.02 * d;
  std::int64_t id = 0;
  for (const double zl : {z - d, z}) {
    const double shift = zl < z ? 0.5 * a : 0.0;
    for (int i = -20; i <= 20; ++i)
      for (int j = -20; j <= 20; ++j) {
        const double x0 = a * (i + 0.5 * (j & 1)) + shift, y0 = a * std::sqrt(3.0) / 2 * j + shift;
        const double r = std::hypot(x0, y0);
        if (r < c.vane_radius_m + 0.5 * d || r > c.radius_m - 0.5 * d) continue;
        f.x.push_back(std::cos(angle) * x0 - std::sin(angle) * y0);
        f.y.push_back(std::sin(angle) * x0 + std::cos(angle) * y0);
        f.z.push_back(zl);
        f.id.push_back(id++);
        f.mobile.push_back(true);
      }
  }
  return f;
}

/// The intensity centroid of `img` (8-bit) above `floor` within `half` px of (x, y).
void centroid(const cv::Mat& img, double x, double y, int half, double floor, double& cx, double& cy) {
  double s = 0, sx = 0, sy = 0;
  for (int i = static_cast<int>(y) - half; i <= static_cast<int>(y) + half; ++i)
    for (int j = static_cast<int>(x) - half; j <= static_cast<int>(x) + half; ++j) {
      const double w = std::max(0.0, img.at<std::uint8_t>(i, j) - floor);
      s += w;
      sx += w * j;
      sy += w * i;
    }
  cx = sx / s;
  cy = sy / s;
}

}  // namespace

TEST_CASE("cup view: a bead appears at the pixel the pinhole and orthographic formulas give",
          "[synth][cup_view]") {
  synth::CupGeometry cup = small_cup();
  cup.vane_blades = 0;
  const double z_s = 0.006;  // the bead surface
  synth::CupLook look;
  look.noise = 0;
  look.albedo_spread = 0;
  look.shading.light_elevation_deg = 90;  // light along the axis: the shaded disc is symmetric
  look.shading.specular = 0;
  for (const bool ortho : {false, true}) {
    const synth::DownCamera cam = synth::cup_camera(cup, z_s, ortho, 1280, 720, 5e-5, 0.3);
    // Off-axis and 2 mm above the surface: a pinhole sees it larger and further out.
    const double X = 0.011, Y = -0.007, Z = z_s + 0.002;
    double ex = 0, ey = 0;
    if (ortho) {
      ex = 639.5 + X / 5e-5;
      ey = 359.5 - Y / 5e-5;
    } else {
      const double f = 0.3 / 5e-5;  // focal length, px
      ex = 639.5 + f * X / (z_s + 0.3 - Z);
      ey = 359.5 - f * Y / (z_s + 0.3 - Z);
    }
    synth::CupBeads one;
    one.x = {X};
    one.y = {Y};
    one.z = {Z};
    one.id = {0};
    one.mobile = {true};
    const auto beads = synth::project_beads(cam, cup, one, z_s, look);
    REQUIRE(beads.x.size() == 1);
    CHECK(beads.x[0] == Approx(ex).margin(1e-9));
    CHECK(beads.y[0] == Approx(ey).margin(1e-9));
    const cv::Mat img = synth::render_cup_frame(cam, cup, z_s, beads, 0.0, look, 0);
    double cx = 0, cy = 0;
    // The gaps' level is 0.03 of full scale (8 grey levels); the bead is ~80 px across.
    centroid(img, ex, ey, 50, 8.0, cx, cy);
    INFO((ortho ? "orthographic" : "pinhole") << ": centroid " << cx << ", " << cy << " expected " << ex << ", "
                                              << ey);
    CHECK(std::abs(cx - ex) < 0.1);
    CHECK(std::abs(cy - ey) < 0.1);
  }
}

TEST_CASE("cup view: the rim's top face is the circle that --detect-cup fits, within 1 px",
          "[synth][cup_view]") {
  const synth::CupGeometry cup = small_cup();
  const double z_s = 0.006;
  for (const bool ortho : {false, true}) {
    const synth::DownCamera cam = synth::cup_camera(cup, z_s, ortho, 1280, 720, core::kUnset, 0.5);
    const synth::CupImage im = synth::cup_image(cam, cup, z_s);
    synth::CupLook look;
    const auto beads = synth::project_beads(cam, cup, packing(cup, z_s, 0.0), z_s, look);
    const cv::Mat img = synth::render_cup_frame(cam, cup, z_s, beads, 0.2, look, 3);
    const profile::CircleFit c = profile::detect_cup_circle(img, 0.8 * im.rim_radius_px, 1.2 * im.rim_radius_px);
    // The rim is drawn as its top face, a bright ring of rim_width_px beyond the wall's
    // inner edge: detection fits the ring's middle line.
    const double line = im.rim_radius_px + 0.5 * look.rim_width_px;
    INFO((ortho ? "orthographic" : "pinhole") << ": fitted r = " << c.radius_px << " drawn " << line << ", centre "
                                              << c.centre_x_px << ", " << c.centre_y_px);
    CHECK(std::abs(c.radius_px - line) < 1.0);
    CHECK(std::hypot(c.centre_x_px - im.centre_x_px, c.centre_y_px - im.centre_y_px) < 1.0);
  }
}

TEST_CASE("cup view: a rigid rotation of packing and vane, filmed and measured by PIV, gives v = omega r "
          "within 2 % between vane and wall",
          "[synth][cup_view]") {
  // A cup of 15 bead diameters filmed at 12 px per bead, the size at which the PIV's
  // 16 px final window resolves beads (at 54 px per bead it reads a uniform 2 px shift
  // as 1.72 px: docs/sim.md, "Closed loop").
  synth::CupGeometry cup = small_cup();
  cup.radius_m = 0.06;
  cup.vane_radius_m = 0.025;
  const double z_s = 0.006, dtheta = 0.01;  // rad per frame: 1.1 px at the vane, 1.8 px at the wall
  const double scale = cup.bead_diameter_m / 12.0;
  for (const bool ortho : {false, true}) {
    const synth::DownCamera cam = synth::cup_camera(cup, z_s, ortho, 480, 400, scale, 0.5);
    const synth::CupImage im = synth::cup_image(cam, cup, z_s);
    synth::CupLook look;  // the default look: highlights, albedo scatter, 1 % noise
    const cv::Mat a = synth::render_cup_frame(cam, cup, z_s,
                                                 synth::project_beads(cam, cup, packing(cup, z_s, 0.0), z_s, look),
                                                 0.0, look, 0);
    const cv::Mat b = synth::render_cup_frame(
        cam, cup, z_s, synth::project_beads(cam, cup, packing(cup, z_s, dtheta), z_s, look), dtheta, look, 1);
    // Masks: the vane (both frames) and outside the annulus, as `piv` builds them.
    auto mask = [&](double angle) {
      cv::Mat m(a.size(), CV_8U);
      for (int i = 0; i < m.rows; ++i)
        for (int j = 0; j < m.cols; ++j) {
          const double r = std::hypot(j - im.centre_x_px, i - im.centre_y_px);
          m.at<std::uint8_t>(i, j) =
              (r < im.vane_surface_radius_px || r > im.cup_radius_px ||
               synth::inside_vane(j, i, im.centre_x_px, im.centre_y_px, angle, 4, im.vane_half_width_px + 2,
                                  im.vane_radius_px + 2))
                  ? 255
                  : 0;
        }
      return m;
    };
    const piv::PivEngine engine(piv::PivOptions{});  // the defaults: 64, 32, 16 px windows
    const core::VectorField f = engine.process(a, b, mask(0.0), mask(dtheta)).field;
    // Per ring of one bead width: the mean tangential displacement against dtheta r.
    const double d_px = cup.bead_diameter_m * cam.px_per_m(z_s);
    int rings = 0;
    // Rings of one bead from a bead off the vane to a bead off the wall (the windows
    // there straddle the masks).
    for (double r0 = im.vane_surface_radius_px + d_px; r0 + d_px <= im.cup_radius_px - d_px; r0 += d_px) {
      double s = 0, n = 0;
      for (std::size_t i = 0; i < f.ny(); ++i)
        for (std::size_t j = 0; j < f.nx(); ++j) {
          const std::size_t q = f.index(i, j);
          if (f.flag[q] != core::VectorFlag::kValid) continue;
          const double dx = f.x_px[j] - im.centre_x_px, dy = f.y_px[i] - im.centre_y_px, r = std::hypot(dx, dy);
          if (r < r0 || r >= r0 + d_px) continue;
          // Counter-clockwise on the image (y down): tangent (dy, -dx) / r.
          s += (f.u_px[q] * dy - f.v_px[q] * dx) / r / (dtheta * r);
          n += 1;
        }
      REQUIRE(n > 20);
      INFO((ortho ? "orthographic" : "pinhole") << " d = " << d_px << " px: ring at " << r0 << " px: v / (omega r) = " << s / n);
      CHECK(std::abs(s / n - 1.0) < 0.02);
      ++rings;
    }
    CHECK(rings >= 5);
  }
}

TEST_CASE("cup view: the visible beads are those whose middle no higher bead covers, each with its motion",
          "[synth]") {
  synth::CupImage im;
  im.centre_x_px = 100;
  im.centre_y_px = 100;
  im.cup_radius_px = 90;
  synth::ProjectedBeads a, b;
  auto add = [](synth::ProjectedBeads& p, std::int64_t id, double x, double y, double top) {
    p.id.push_back(id);
    p.x.push_back(x);
    p.y.push_back(y);
    p.top.push_back(top);
    p.diameter.push_back(20);
    p.albedo.push_back(1);
  };
  add(a, 0, 60, 100, 20);   // on top
  add(a, 1, 64, 100, 10);   // lower, its middle under bead 0: not visible
  add(a, 2, 120, 100, 10);  // alone
  add(a, 3, 150, 60, 10);   // alone, but gone in frame b
  add(a, 4, 195, 100, 10);  // beyond the cup radius
  add(b, 0, 61, 100.5, 20);
  add(b, 1, 64, 100, 10);
  add(b, 2, 119, 102, 10);
  add(b, 4, 195, 100, 10);
  const synth::VisibleBeads v = synth::visible_beads(a, b, im, 0, 0.0);
  REQUIRE(v.x_px.size() == 2);
  CHECK(v.x_px[0] == 60);
  CHECK(v.u_px[0] == 1);
  CHECK(v.v_px[0] == 0.5);
  CHECK(v.x_px[1] == 120);
  CHECK(v.u_px[1] == -1);
  CHECK(v.v_px[1] == 2);
}
