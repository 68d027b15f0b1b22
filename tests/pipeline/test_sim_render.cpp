// `shearzone sim render` and `sim check` as jobs: renders are byte-identical and carry
// the geometry, a periodic sector is filmed whole, and the closed loop writes its table
// and holds the camera's truth. (The renderer itself: tests/synth/test_cup_view.cpp.)
#include <malloc.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

#include <catch2/catch.hpp>
#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/core/metadata.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/io/field_file.hpp"
#include "shearzone/pipeline/sim_check_job.hpp"
#include "shearzone/pipeline/sim_job.hpp"
#include "shearzone/pipeline/sim_render_job.hpp"
#include "shearzone/profile/width.hpp"
#include "support/temp_dir.hpp"

using namespace shearzone;
using Catch::Matchers::Contains;
using shearzone::testing::TempDir;

namespace {

constexpr double kPi = std::numbers::pi;

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

TEST_CASE("sim render: a filmed run renders to the same bytes twice, camera.json and piv.toml carry the geometry",
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

// Same frames, same bytes, whatever the heap held: FFmpeg's H.264 encoder (through
// OpenCV 4.6) reads heap memory nothing wrote, and `sim render --codec avc1` of one run
// gave three different streams over 9 runs on a loaded machine until the writer had
// glibc fill what it hands out (io/video.cpp). Here glibc fills the heap with another
// byte for each of two renders of 60 frames at 144 x 108 (8 px per bead), as
// MALLOC_PERTURB_ would; without the writer's own fill the two streams differ.
TEST_CASE("sim render: an H.264 clip has the same bytes whatever the heap held", "[pipeline][sim][render]") {
  TempDir dir("sim_render_heap");
  std::string scene = testing::read_file(std::filesystem::path(SHEARZONE_DATA_SAMPLES_DIR) / "sim" / "filmed_cup.toml");
  const std::string from = "duration_s = 0.16";
  REQUIRE(scene.find(from) != std::string::npos);
  scene.replace(scene.find(from), from.size(), "duration_s = 2.4");  // 60 frames at 25 fps
  testing::write_file(dir / "s.toml", scene);
  pipeline::SimJobOptions so;
  so.scene = dir / "s.toml";
  so.output_dir = dir / "run";
  (void)pipeline::run_sim_job(so, core::standard_metadata("test"));
  pipeline::SimRenderOptions ro;
  ro.run_dir = dir / "run";
  ro.codec = "avc1";
  ro.width_px = 144;
  ro.height_px = 108;
  std::vector<std::string> bytes;
  for (const int fill : {0x3c, 0xc3}) {
    ro.output_dir = dir / fmt::format("r{}", fill);
    mallopt(M_PERTURB, fill);
    (void)pipeline::run_sim_render(ro, core::standard_metadata("test"));
    mallopt(M_PERTURB, 0);
    bytes.push_back(read_bytes(ro.output_dir / "video.mp4"));
  }
  INFO(bytes[0].size() << " and " << bytes[1].size() << " bytes");
  CHECK((bytes[0] == bytes[1]));
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
// the data-samples cup at 8 px per bead with MPEG-4 and at 15, 25, 35 and 50 px per bead
// with MPEG-4 and H.264, PIV defaults (windows sized to the beads, gradient residual, the
// predictor's quadratic fit chosen for beads): the video's r_c within d/4 of the camera's
// truth with the same status. Measured here: -0.07 d (8 px, mp4v; with the Gaussian
// smoothing -0.22, with 16 px final windows -1.02), -0.02 / -0.13 d (15 px, mp4v / avc1),
// +0.02 / -0.00 (25 px), -0.05 / -0.06 (35 px), -0.00 / -0.01 (50 px).
// Not met: 8 px with H.264 (-0.52 d: the encoder leaves small motions of beads this small
// out).
TEST_CASE("closed loop: at 8 (MPEG-4), 15, 25, 35 and 50 px per bead (MPEG-4 and H.264), the video's r_c lies "
          "within d/4 of the camera's truth with the same status",
          "[pipeline][sim][render][slow]") {
  TempDir dir("closed_loop_sizes");
  run_cup_protocol(dir, "[0.15]");
  const double d = 0.004;
  constexpr double kMaxErrorOverD = 0.25;  // the gate
  struct Case {
    int w, h;  // the rim fills 90 % of the height: 14.4 px per bead per 192 px
    const char* codec;
  };
  for (const Case c : {Case{142, 106, "mp4v"}, Case{268, 200, "mp4v"}, Case{268, 200, "avc1"}, Case{446, 334, "mp4v"},
                       Case{446, 334, "avc1"}, Case{624, 468, "mp4v"}, Case{624, 468, "avc1"}, Case{888, 666, "mp4v"},
                       Case{888, 666, "avc1"}}) {
    pipeline::SimCheckOptions o = check_options(dir, 5e-4);
    o.output_dir = dir / fmt::format("check_{}_{}", c.h, c.codec);
    o.render.width_px = c.w;
    o.render.height_px = c.h;
    o.render.codec = c.codec;
    o.width.bootstrap = 200;
    const auto rows = pipeline::run_sim_check(o, core::standard_metadata("test"));
    REQUIRE(rows.size() == 1);
    const auto& r = rows[0];
    INFO(c.w << "x" << c.h << " " << c.codec << ": r_c video " << r.video.rc_m << " ("
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
