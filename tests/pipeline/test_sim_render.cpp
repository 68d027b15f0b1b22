// `shearzone sim render` and `sim check` as jobs: the virtual camera projects where the
// pinhole and orthographic formulas say, the rim it draws is the circle --detect-cup
// finds, renders are byte-identical, a rigid rotation of the packing filmed and measured
// by PIV gives v = omega r, and the closed loop writes its table.
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

#include <catch2/catch.hpp>
#include <fmt/format.h>
#include <opencv2/core.hpp>

#include "shearzone/core/error.hpp"
#include "shearzone/core/metadata.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/io/field_file.hpp"
#include "shearzone/pipeline/sim_check_job.hpp"
#include "shearzone/pipeline/sim_job.hpp"
#include "shearzone/pipeline/sim_render_job.hpp"
#include "shearzone/piv/piv.hpp"
#include "shearzone/profile/geometry.hpp"
#include "shearzone/synth/render.hpp"
#include "support/temp_dir.hpp"

using namespace shearzone;
using Catch::Matchers::Contains;
using shearzone::testing::TempDir;

namespace {

constexpr double kPi = std::numbers::pi;

/// The data-samples cup: radius 24 mm, 4 mm beads, a four-blade vane of radius 10 mm.
sim::FilmedCup small_cup() {
  sim::FilmedCup c;
  c.bead_diameter_m = 0.004;
  c.cup_radius_m = 0.024;
  c.cup_height_m = 0.02;
  c.vane_blades = 4;
  c.vane_radius_m = 0.01;
  c.vane_height_m = 0.02;
  return c;
}

/// A hexagonal layer of beads at height z in the annulus between the vane and the wall,
/// over a floor layer one diameter below, turned by `angle` about the axis.
sim::FrameBodies packing(const sim::FilmedCup& c, double z, double angle) {
  sim::FrameBodies f;
  const double d = c.bead_diameter_m, a = 1.02 * d;
  std::int64_t id = 0;
  for (const double zl : {z - d, z}) {
    const double shift = zl < z ? 0.5 * a : 0.0;
    for (int i = -20; i <= 20; ++i)
      for (int j = -20; j <= 20; ++j) {
        const double x0 = a * (i + 0.5 * (j & 1)) + shift, y0 = a * std::sqrt(3.0) / 2 * j + shift;
        const double r = std::hypot(x0, y0);
        if (r < c.vane_radius_m + 0.5 * d || r > c.cup_radius_m - 0.5 * d) continue;
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

/// data-samples/sim/filmed_cup.toml (60 settled beads, 5 frames at 25 fps) run into dir/run.
void film_run(const TempDir& dir) {
  pipeline::SimJobOptions so;
  so.scene = std::filesystem::path(SHEARZONE_DATA_SAMPLES_DIR) / "sim" / "filmed_cup.toml";
  so.output_dir = dir / "run";
  (void)pipeline::run_sim_job(so, core::standard_metadata("test"));
}

/// The closed loop of dir/run into dir/check, filmed at 256 x 192 (14 px per bead), v_c given.
pipeline::SimCheckOptions check_options(const TempDir& dir, double v_c) {
  pipeline::SimCheckOptions o;
  o.run_dir = dir / "run";
  o.output_dir = dir / "check";
  o.render.width_px = 256;
  o.render.height_px = 192;
  o.width.v_c_m_per_s = v_c;
  return o;
}

/// data-samples/sim/vane_cup.toml with branches at `phi0_list` (a TOML array), run through
/// its protocol into dir/run.
void run_cup_protocol(const TempDir& dir, const std::string& phi0_list) {
  std::string scene = testing::read_file(std::filesystem::path(SHEARZONE_DATA_SAMPLES_DIR) / "sim" / "vane_cup.toml");
  const std::string from = "phi0_rad = [0.02, 0.3]";
  REQUIRE(scene.find(from) != std::string::npos);
  scene.replace(scene.find(from), from.size(), "phi0_rad = " + phi0_list);
  testing::write_file(dir / "cup.toml", scene);
  pipeline::SimJobOptions so;
  so.scene = dir / "cup.toml";
  so.output_dir = dir / "run";
  (void)pipeline::run_sim_protocol(so, core::standard_metadata("test"));
}

std::string read_bytes(const std::filesystem::path& p) { return testing::read_file(p); }

}  // namespace

TEST_CASE("sim render: a bead appears at the pixel the pinhole and orthographic formulas give",
          "[pipeline][sim][render]") {
  sim::FilmedCup cup = small_cup();
  cup.vane_blades = 0;
  const double z_s = 0.006;  // the bead surface
  pipeline::CupLook look;
  look.noise = 0;
  look.albedo_spread = 0;
  look.shading.light_elevation_deg = 90;  // light along the axis: the shaded disc is symmetric
  look.shading.specular = 0;
  for (const bool ortho : {false, true}) {
    const synth::DownCamera cam = pipeline::cup_camera(cup, z_s, ortho, 1280, 720, 5e-5, 0.3);
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
    sim::FrameBodies one;
    one.x = {X};
    one.y = {Y};
    one.z = {Z};
    one.id = {0};
    one.mobile = {true};
    const auto beads = pipeline::project_beads(cam, cup, one, z_s, look);
    REQUIRE(beads.x.size() == 1);
    CHECK(beads.x[0] == Approx(ex).margin(1e-9));
    CHECK(beads.y[0] == Approx(ey).margin(1e-9));
    const cv::Mat img = pipeline::render_cup_frame(cam, cup, z_s, beads, 0.0, look, 0);
    double cx = 0, cy = 0;
    // The gaps' level is 0.03 of full scale (8 grey levels); the bead is ~80 px across.
    centroid(img, ex, ey, 50, 8.0, cx, cy);
    INFO((ortho ? "orthographic" : "pinhole") << ": centroid " << cx << ", " << cy << " expected " << ex << ", "
                                              << ey);
    CHECK(std::abs(cx - ex) < 0.1);
    CHECK(std::abs(cy - ey) < 0.1);
  }
}

TEST_CASE("sim render: the rim's top face is the circle that --detect-cup fits, within 1 px",
          "[pipeline][sim][render]") {
  const sim::FilmedCup cup = small_cup();
  const double z_s = 0.006;
  for (const bool ortho : {false, true}) {
    const synth::DownCamera cam = pipeline::cup_camera(cup, z_s, ortho, 1280, 720, core::kUnset, 0.5);
    const pipeline::CupImage im = pipeline::cup_image(cam, cup, z_s);
    pipeline::CupLook look;
    const auto beads = pipeline::project_beads(cam, cup, packing(cup, z_s, 0.0), z_s, look);
    const cv::Mat img = pipeline::render_cup_frame(cam, cup, z_s, beads, 0.2, look, 3);
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

TEST_CASE("sim render: a rigid rotation of packing and vane, filmed and measured by PIV, gives v = omega r "
          "within 2 % between vane and wall",
          "[pipeline][sim][render]") {
  // A cup of 15 bead diameters filmed at 12 px per bead, the size at which the PIV's
  // 16 px final window resolves beads (at 54 px per bead it reads a uniform 2 px shift
  // as 1.72 px: docs/sim.md, "Closed loop").
  sim::FilmedCup cup = small_cup();
  cup.cup_radius_m = 0.06;
  cup.vane_radius_m = 0.025;
  const double z_s = 0.006, dtheta = 0.01;  // rad per frame: 1.1 px at the vane, 1.8 px at the wall
  const double scale = cup.bead_diameter_m / 12.0;
  for (const bool ortho : {false, true}) {
    const synth::DownCamera cam = pipeline::cup_camera(cup, z_s, ortho, 480, 400, scale, 0.5);
    const pipeline::CupImage im = pipeline::cup_image(cam, cup, z_s);
    pipeline::CupLook look;  // the default look: highlights, albedo scatter, 1 % noise
    const cv::Mat a = pipeline::render_cup_frame(cam, cup, z_s,
                                                 pipeline::project_beads(cam, cup, packing(cup, z_s, 0.0), z_s, look),
                                                 0.0, look, 0);
    const cv::Mat b = pipeline::render_cup_frame(
        cam, cup, z_s, pipeline::project_beads(cam, cup, packing(cup, z_s, dtheta), z_s, look), dtheta, look, 1);
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

TEST_CASE("sim render: a filmed run renders to the same bytes twice; camera.json and piv.toml carry the geometry",
          "[pipeline][sim][render]") {
  TempDir dir("sim_render");
  film_run(dir);
  REQUIRE(std::filesystem::exists(dir / "run" / "frames.h5"));
  const sim::FramesFile frames(dir / "run" / "frames.h5");
  CHECK(frames.size() == 5);  // frames 0..4 of 0.16 s at 25 fps
  CHECK(frames.cup().vane_blades == 4);
  CHECK(frames.cup().phi0_rad == 0.3);
  pipeline::SimRenderOptions ro;
  ro.run_dir = dir / "run";
  ro.format = "png";
  ro.width_px = 320;
  ro.height_px = 240;
  for (const char* out : {"r1", "r2"}) {
    ro.output_dir = dir / out;
    const auto sum = pipeline::run_sim_render(ro, core::standard_metadata("test"));
    CHECK(sum.frames == 5);
  }
  for (const char* f : {"frame_000000.png", "frame_000004.png", "vane_angle.csv", "piv.toml", "camera.json"})
    CHECK(read_bytes(dir / "r1" / f) == read_bytes(dir / "r2" / f));
  const auto angles = io::read_csv(dir / "r1" / "vane_angle.csv");
  const auto t = angles.numeric_column("time_s"), phi = angles.numeric_column("angle_rad");
  REQUIRE(t.size() == 5);
  for (std::size_t k = 0; k < t.size(); ++k) {
    CHECK(t[k] == Approx(k / 25.0).margin(1e-9));
    CHECK(phi[k] == Approx(0.3 * std::sin(2 * kPi * t[k])).margin(1e-9));
  }
  const std::string toml = read_bytes(dir / "r1" / "piv.toml");
  CHECK_THAT(toml, Contains("centre = [159.5, 119.5]"));
  CHECK_THAT(toml, Contains("vane = [4, "));
  CHECK_THAT(toml, Contains("f-hz = 1\n"));
  CHECK_THAT(read_bytes(dir / "r1" / "camera.json"), Contains("\"projection\": \"pinhole\""));
  // Refusals: a run without frames, a bad option, an existing output.
  ro.run_dir = dir.path();
  ro.output_dir = dir / "r3";
  CHECK_THROWS_WITH(pipeline::run_sim_render(ro, {}), Contains("frames.h5: not found"));
  ro.run_dir = dir / "run";
  ro.look.jpeg_quality = 101;
  CHECK_THROWS_AS(pipeline::run_sim_render(ro, {}), ConfigError);
  ro.look.jpeg_quality = 0;
  ro.output_dir = dir / "r1";
  CHECK_THROWS_WITH(pipeline::run_sim_render(ro, {}), Contains("use --force"));
  CHECK(!std::filesystem::exists(dir / "r3"));
}

TEST_CASE("sim check: a filmed run through the closed loop writes one row per branch and setting, and refuses "
          "what it cannot run",
          "[pipeline][sim][render]") {
  TempDir dir("sim_check");
  film_run(dir);
  pipeline::SimCheckOptions o = check_options(dir, 2e-3);
  o.width.bootstrap = 200;
  o.settings = {{{32, 16, 8}, 1, ""}, {{32, 16, 8}, 2, ""}};
  o.piv.size_windows_to_texture = false;  // the windows as given (`sim check --windows`)
  const auto rows = pipeline::run_sim_check(o, core::standard_metadata("test"));
  REQUIRE(rows.size() == 2);
  CHECK(rows[0].branch == "run");
  CHECK(rows[0].setting == "w32-16-8_k1");
  CHECK(rows[0].pairs == 4);
  CHECK(rows[1].pairs == 3);  // pairs (0,2), (1,3), (2,4)
  CHECK(rows[0].compared_vectors > 100);
  CHECK(rows[0].piv_rms_error_px < 1.0);  // a few frames of a barely moving packing
  const auto table = io::read_csv(dir / "check" / "closed_loop.csv");
  CHECK(table.text_column("setting") == std::vector<std::string>{"w32-16-8_k1", "w32-16-8_k2"});
  for (const char* f : {"run/video/video.mp4", "run/static.mp4", "run/truth_centres.h5", "run/truth_surface_width.csv",
                        "run/w32-16-8_k1/static_fields.h5", "run/w32-16-8_k2/width.csv"})
    CHECK(std::filesystem::exists(dir / "check" / f));
  // Again: refused without force (nothing rendered first), accepted with it.
  CHECK_THROWS_WITH(pipeline::run_sim_check(o, {}), Contains("give --force"));
  o.force = true;
  CHECK(pipeline::run_sim_check(o, {}).size() == 2);
  // A window the PIV refuses is refused before any rendering.
  o.settings = {{{48, 24, 12}, 1, ""}};
  o.output_dir = dir / "check2";
  CHECK_THROWS_AS(pipeline::run_sim_check(o, {}), ConfigError);
  CHECK(!std::filesystem::exists(dir / "check2"));
}

TEST_CASE("closed loop: on the data-samples cup at three amplitudes (no zone, a zone, the whole cup) the video's "
          "r_c lies within d/2 of the camera's truth with the same status",
          "[pipeline][sim][render][slow]") {
  // The data-samples cup (150 beads, 4 s pre-shear at 1 Hz), branches of two cycles at
  // 0.5 Hz, filmed at 14 px per bead (256 x 192 px), v_c = 0.5 mm/s.
  TempDir dir("closed_loop");
  run_cup_protocol(dir, "[0.05, 0.15, 0.3]");
  pipeline::SimCheckOptions o = check_options(dir, 5e-4);
  o.settings = {{{32, 16, 8}, 1, ""}};
  const auto rows = pipeline::run_sim_check(o, core::standard_metadata("test"));
  REQUIRE(rows.size() == 3);
  const double d = 0.004;
  const std::vector<profile::WidthStatus> expect{profile::WidthStatus::kBelowAtVane, profile::WidthStatus::kOk,
                                                 profile::WidthStatus::kNeverBelow};
  for (std::size_t k = 0; k < 3; ++k) {
    const auto& r = rows[k];
    INFO(r.branch << ": r_c video " << r.video.rc_m << " (" << profile::width_status_name(r.video.status)
                  << "), camera truth " << r.centres.rc_m << " (" << profile::width_status_name(r.centres.status)
                  << "), surface field " << r.surface.rc_m);
    CHECK(r.centres.status == expect[k]);
    CHECK(r.video.status == r.centres.status);
    CHECK(std::abs(r.video.rc_m - r.centres.rc_m) <= 0.5 * d);
    // The surface field's material points carry the beads' spin, which shiny spheres do
    // not show: its r_c is never below the camera's (measured: +1.1 d at 0.15 rad).
    CHECK(r.surface.rc_m >= r.centres.rc_m - 1e-12);
  }
}

// Issue 33's gate where it is met (docs/sim.md, "Bead size, codec and the closed loop"):
// the data-samples cup at 15 and 35 px per bead, MPEG-4 and H.264, PIV defaults (windows
// sized to the beads, gradient residual): the video's r_c within d/4 of the camera's truth
// with the same status. Measured: -0.09 / -0.18 d (15 px, mp4v / avc1; H.264 is not
// bit-reproducible: -0.17 to -0.20 d over three runs), -0.10 / -0.09 d (35 px); before:
// -0.37 to -0.87 d. At 8 px per bead it is not met (about -1 d).
TEST_CASE("closed loop: at 15 and 35 px per bead, MPEG-4 and H.264, the video's r_c lies within d/4 of the "
          "camera's truth with the same status",
          "[pipeline][sim][render][slow]") {
  TempDir dir("closed_loop_sizes");
  run_cup_protocol(dir, "[0.15]");
  const double d = 0.004;
  constexpr double kMaxErrorOverD = 0.25;  // the gate
  struct Size {
    int w, h;  // the rim fills 90 % of the height: 14.4 px per bead per 192 px
  };
  for (const Size sz : {Size{268, 200}, Size{624, 468}})
    for (const char* codec : {"mp4v", "avc1"}) {
      pipeline::SimCheckOptions o = check_options(dir, 5e-4);
      o.output_dir = dir / fmt::format("check_{}_{}", sz.h, codec);
      o.render.width_px = sz.w;
      o.render.height_px = sz.h;
      o.render.codec = codec;
      o.width.bootstrap = 200;
      const auto rows = pipeline::run_sim_check(o, core::standard_metadata("test"));
      REQUIRE(rows.size() == 1);
      const auto& r = rows[0];
      INFO(sz.w << "x" << sz.h << " " << codec << ": r_c video " << r.video.rc_m << " ("
                << profile::width_status_name(r.video.status) << "), camera truth " << r.centres.rc_m << " ("
                << profile::width_status_name(r.centres.status) << "), setting " << r.setting);
      CHECK(r.centres.status == profile::WidthStatus::kOk);
      CHECK(r.video.status == r.centres.status);
      CHECK(std::abs(r.video.rc_m - r.centres.rc_m) <= kMaxErrorOverD * d);
    }
}

TEST_CASE("sim render: a periodic quarter is filmed whole, each bead in its four images, and goes through the "
          "closed loop",
          "[pipeline][sim][render]") {
  TempDir dir("sim_render_sector");
  std::string scene = testing::read_file(std::filesystem::path(SHEARZONE_DATA_SAMPLES_DIR) / "sim" / "filmed_cup.toml");
  for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
           {"bead_diameter_m = 0.004\n", "bead_diameter_m = 0.004\nsectors = 4\n"}, {"count = 60", "count = 15"}}) {
    REQUIRE(scene.find(from) != std::string::npos);
    scene.replace(scene.find(from), from.size(), to);
  }
  testing::write_file(dir / "s.toml", scene);
  pipeline::SimJobOptions so;
  so.scene = dir / "s.toml";
  so.output_dir = dir / "run";
  const auto sum = pipeline::run_sim_job(so, core::standard_metadata("test"));
  const sim::FramesFile frames(dir / "run" / "frames.h5");
  CHECK(frames.cup().sectors == 4);
  const sim::FrameBodies b = frames.frame(0);
  CHECK(b.x.size() == 4u * static_cast<std::size_t>(sum.bodies - sum.kinematic_bodies));
  // Image j of a bead is the bead turned by j quarter turns about the axis.
  const double r0 = std::hypot(b.x[0], b.y[0]);
  const std::size_t per = b.x.size() / 4;
  for (std::size_t j = 1; j < 4; ++j) {
    CHECK(b.id[j * per] == b.id[0] + static_cast<std::int64_t>(j));
    CHECK(std::hypot(b.x[j * per], b.y[j * per]) == Approx(r0).epsilon(1e-12));
    CHECK(std::atan2(b.y[j * per], b.x[j * per]) - std::atan2(b.y[0], b.x[0]) ==
          Approx(std::remainder(j * kPi / 2 + std::atan2(b.y[0], b.x[0]), 2 * kPi) - std::atan2(b.y[0], b.x[0]))
              .margin(1e-12));
  }
  // The closed loop takes it like a whole cup: the camera's truth sees beads in all four
  // quarters, and the PIV is compared with it there.
  pipeline::SimCheckOptions o = check_options(dir, 2e-3);
  o.width.bootstrap = 100;
  o.settings = {{{32, 16, 8}, 1, ""}};
  const auto rows = pipeline::run_sim_check(o, core::standard_metadata("test"));
  REQUIRE(rows.size() == 1);
  CHECK(rows[0].pairs == 4);
  CHECK(rows[0].compared_vectors > 100);
  const auto truth = io::open_field_file(dir / "check" / "run" / "truth_centres.h5", core::kUnset);
  core::VectorField f;
  double ta = 0, dt = 0;
  truth->read(0, f, ta, dt);
  int quarters[4] = {0, 0, 0, 0};
  const double cx = truth->attribute("centre_x_px"), cy = truth->attribute("centre_y_px");
  for (std::size_t i = 0; i < f.ny(); ++i)
    for (std::size_t jx = 0; jx < f.nx(); ++jx)
      if (f.flag[f.index(i, jx)] == core::VectorFlag::kValid)
        ++quarters[(f.x_px[jx] > cx ? 1 : 0) + (f.y_px[i] > cy ? 2 : 0)];
  for (const int q : quarters) CHECK(q > 10);
}
