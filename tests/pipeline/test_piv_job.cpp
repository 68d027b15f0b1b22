#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include <catch2/catch.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "shearzone/core/error.hpp"
#include "shearzone/core/version.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/io/hdf5.hpp"
#include "shearzone/io/image.hpp"
#include "shearzone/io/video.hpp"
#include "shearzone/pipeline/piv_job.hpp"
#include "shearzone/piv/mask.hpp"
#include "shearzone/pipeline/synth_job.hpp"
#include "shearzone/synth/generator.hpp"
#include "support/temp_dir.hpp"

using namespace shearzone;
using Catch::Matchers::Contains;
namespace fs = std::filesystem;

namespace {

/// Renders a synthetic clip (rotation, 256 x 192) into `dir`.
void make_clip(const fs::path& dir, int frames, const std::string& format) {
  pipeline::SynthJobOptions j;
  j.synth.image.width_px = 256;
  j.synth.image.height_px = 192;
  j.synth.field.kind = synth::FieldKind::kRotation;
  j.synth.field.omega_rad = 0.01;
  j.synth.sequence.frames = frames;
  j.format = format;
  j.out_dir = dir;
  pipeline::run_synth_job(j, {});
}

pipeline::PivJobOptions job(std::vector<std::string> inputs, const fs::path& out) {
  pipeline::PivJobOptions o;
  o.inputs = std::move(inputs);
  o.output = out;
  o.piv.windows_px = {32, 16};
  return o;
}

/// A clip of `frames` rotation frames in tmp/clip (make_clip: "avi" or "png") and the job
/// that reads it into `out`.
pipeline::PivJobOptions clip_job(const testing::TempDir& tmp, int frames, const std::string& format,
                                 const fs::path& out) {
  make_clip(tmp / "clip", frames, format);
  return job({(tmp / "clip" / (format == "png" ? "frame_*.png" : "video." + format)).string()}, out);
}

/// A bead clip (25 fps) around a four-blade vane (half-width 5 px, radius 70 px)
/// oscillating as phi = 0.3 sin(pi t), with a shear zone whose rigid core turns with
/// the vane.
pipeline::SynthJobOptions vane_bead_clip(const fs::path& dir, int width, int height,
                                         double bead_px, double w_px, int frames,
                                         const std::string& format) {
  pipeline::SynthJobOptions s;
  s.synth.texture = synth::TextureKind::kBeads;
  s.synth.image.width_px = width;
  s.synth.image.height_px = height;
  s.synth.beads.diameter_px = bead_px;
  s.synth.field.kind = synth::FieldKind::kShearZone;
  s.synth.field.r0_px = 70;
  s.synth.field.w_px = w_px;
  s.synth.field.U0_px = 0.3 * std::numbers::pi * 70 / 25;  // the core turns with the vane
  s.synth.sequence.frames = frames;
  s.synth.sequence.oscillate_f_Hz = 0.5;
  s.synth.vane = {4, 5.0, 70.0, 0.3, 0.0, 0.2};
  s.format = format;
  s.out_dir = dir;
  pipeline::run_synth_job(s, {});
  return s;
}

}  // namespace

TEST_CASE("a PIV pair writes the vector CSV with options and conventions", "[pipeline][piv]") {
  testing::TempDir tmp("pivjob");
  pipeline::SynthJobOptions s;
  s.synth.image.width_px = 128;
  s.synth.image.height_px = 96;
  s.synth.field.u_px = 1.25;
  s.synth.field.v_px = -0.5;
  s.out_dir = tmp / "pair";
  pipeline::run_synth_job(s, {});
  const auto out = tmp / "vectors.csv";
  const auto sum = pipeline::run_piv_job(
      job({(tmp / "pair" / "A.png").string(), (tmp / "pair" / "B.png").string()}, out),
      core::standard_metadata("test"));
  CHECK(sum.pairs == 1);
  const auto t = io::read_csv(out);
  CHECK(t.columns == std::vector<std::string>{"x_px", "y_px", "u_px", "v_px", "flag", "peak",
                                              "peak_ratio"});
  CHECK(t.num_rows() == sum.vectors_per_pair);
  CHECK(core::metadata_value(t.metadata, "piv_windows_px") == "32,16");
  CHECK(core::metadata_value(t.metadata, "convention_rotation").find("counter-clockwise") !=
        std::string::npos);
  CHECK(core::metadata_value(t.metadata, "dt_s") == "0.04");
  const auto u = t.numeric_column("u_px");
  const auto flags = t.text_column("flag");
  std::size_t good = 0;
  for (std::size_t r = 0; r < u.size(); ++r)
    if (flags[r] == "valid" && std::abs(u[r] - 1.25) < 0.1) ++good;
  CHECK(good > 0.9 * u.size());
}

TEST_CASE("PIV reads PGM frames and frames named by content, the message names a non-image",
          "[pipeline][piv]") {
  testing::TempDir tmp("pivfmt");
  pipeline::SynthJobOptions s;
  s.synth.image.width_px = 96;
  s.synth.image.height_px = 96;
  s.synth.field.u_px = 1.25;
  s.out_dir = tmp / "pair";
  pipeline::run_synth_job(s, {});
  const cv::Mat a = io::read_image_gray(tmp / "pair" / "A.png"), b = io::read_image_gray(tmp / "pair" / "B.png");
  REQUIRE(cv::imwrite((tmp / "A.pgm").string(), a));
  REQUIRE(cv::imwrite((tmp / "B.pgm").string(), b));
  const auto ref = pipeline::run_piv_job(
      job({(tmp / "pair" / "A.png").string(), (tmp / "pair" / "B.png").string()}, tmp / "png.csv"), {});
  const auto pgm = pipeline::run_piv_job(
      job({(tmp / "A.pgm").string(), (tmp / "B.pgm").string()}, tmp / "pgm.csv"), {});
  CHECK(pgm.vectors_per_pair == ref.vectors_per_pair);
  CHECK(io::read_csv(tmp / "pgm.csv").rows == io::read_csv(tmp / "png.csv").rows);
  // Names that say nothing: the content decides.
  std::filesystem::copy_file(tmp / "A.pgm", tmp / "A.raw0");
  std::filesystem::copy_file(tmp / "B.pgm", tmp / "B.raw0");
  pipeline::run_piv_job(job({(tmp / "A.raw0").string(), (tmp / "B.raw0").string()}, tmp / "raw.csv"), {});
  CHECK(io::read_csv(tmp / "raw.csv").rows == io::read_csv(tmp / "png.csv").rows);
  // A file that is no image: the message names it, not the CSV output.
  testing::write_file(tmp / "B.txt", "not pixels\n");
  CHECK_THROWS_WITH(
      pipeline::run_piv_job(job({(tmp / "A.pgm").string(), (tmp / "B.txt").string()}, tmp / "x.csv"), {}),
      Catch::Contains("B.txt: not an image"));
  CHECK_FALSE(std::filesystem::exists(tmp / "x.csv"));
}

TEST_CASE("a video becomes an HDF5 field file in the documented layout", "[pipeline][piv]") {
  testing::TempDir tmp("pivjob");
  auto o = clip_job(tmp, 5, "avi", tmp / "fields.h5");
  o.centre_x_px = 127.5;
  o.centre_y_px = 95.5;
  o.attributes = {{"m_per_px", "0.0001"}, {"N", "9"}, {"sample", "steel beads"}};
  const auto sum = pipeline::run_piv_job(o, core::standard_metadata("test"));
  CHECK(sum.pairs == 4);
  const auto f = io::H5File::open_read(tmp / "fields.h5");
  const std::size_t nx = f.dims("/grid/x_px")[0], ny = f.dims("/grid/y_px")[0];
  CHECK(nx * ny == sum.vectors_per_pair);
  for (const char* d : {"/pairs/u_px", "/pairs/v_px", "/pairs/peak", "/pairs/peak_ratio", "/pairs/flag"})
    CHECK(f.dims(d) == std::vector<std::size_t>{4, ny, nx});
  CHECK(f.read<std::int64_t>("/pairs/frame_a").data == std::vector<std::int64_t>{0, 1, 2, 3});
  CHECK(f.read<std::int64_t>("/pairs/frame_b").data == std::vector<std::int64_t>{1, 2, 3, 4});
  const auto dt = f.read<double>("/pairs/dt_s").data;
  for (double d : dt) CHECK(d == Approx(0.04).margin(1e-3));
  CHECK(f.attribute_string("/pairs/flag", "mapping") == "0 valid, 1 replaced, 2 masked, 3 invalid");
  CHECK(f.attribute_double("/", "fps") == Approx(25.0));
  CHECK(f.attribute_double("/", "m_per_px") == 0.0001);
  CHECK(f.attribute_double("/", "N") == 9.0);
  CHECK(f.attribute_string("/", "sample") == "steel beads");
  CHECK(f.attribute_double("/", "centre_x_px") == 127.5);
  CHECK(f.attribute_string("/", "shearzone_version") == std::string(kVersion));
  CHECK(f.attribute_string("/", "conventions").find("counter-clockwise") != std::string::npos);
  CHECK(f.attribute_string("/", "options").find("piv_windows_px: 32,16") != std::string::npos);
  CHECK(f.attribute_string("/", "source").find("video.avi") != std::string::npos);
}

TEST_CASE("repeated frames are skipped and counted, the fields are unchanged", "[pipeline][piv]") {
  testing::TempDir tmp("pivjob");
  make_clip(tmp / "clean", 4, "png");
  // The same frames, each written three times (as some encoders repeat frames),
  // at three times the frame rate so that the unique frames keep their times.
  std::vector<std::string> clean, repeated;
  for (int k = 0; k < 4; ++k) {
    const auto src = tmp / "clean" / fmt::format("frame_{:06d}.png", k);
    clean.push_back(src.string());
    for (int r = 0; r < 3; ++r) {
      const auto dst = tmp / fmt::format("rep_{:02d}.png", 3 * k + r);
      fs::copy_file(src, dst);
      repeated.push_back(dst.string());
    }
  }
  auto a = job(clean, tmp / "clean.h5");
  auto b = job({(tmp / "rep_*.png").string()}, tmp / "rep.h5");
  b.fps = 75;
  const auto sa = pipeline::run_piv_job(a, {});
  const auto sb = pipeline::run_piv_job(b, {});
  CHECK(sa.duplicates == 0);
  CHECK(sb.duplicates == 8);
  CHECK(sb.pairs == sa.pairs);
  const auto fa = io::H5File::open_read(tmp / "clean.h5"), fb = io::H5File::open_read(tmp / "rep.h5");
  CHECK(fa.read<float>("/pairs/u_px").data == fb.read<float>("/pairs/u_px").data);
  CHECK(fa.read<float>("/pairs/v_px").data == fb.read<float>("/pairs/v_px").data);
  const auto dta = fa.read<double>("/pairs/dt_s").data, dtb = fb.read<double>("/pairs/dt_s").data;
  for (std::size_t k = 0; k < dta.size(); ++k) CHECK(dtb[k] == Approx(dta[k]));
  CHECK(fb.read<std::int64_t>("/pairs/frame_b").data.front() == 3);  // source index of frame 1
}

TEST_CASE("pair spacing, stride and frame range select the pairs", "[pipeline][piv]") {
  testing::TempDir tmp("pivjob");
  auto o = clip_job(tmp, 8, "png", tmp / "f.h5");
  o.pair_spacing = 2;
  o.stride = 3;
  o.first_frame = 1;
  const auto s = pipeline::run_piv_job(o, {});
  // Unique frames 1..7; pairs start at 1, 4 (and 7 has no partner): (1,3), (4,6).
  CHECK(s.pairs == 2);
  const auto f = io::H5File::open_read(tmp / "f.h5");
  CHECK(f.read<std::int64_t>("/pairs/frame_a").data == std::vector<std::int64_t>{1, 4});
  CHECK(f.read<std::int64_t>("/pairs/frame_b").data == std::vector<std::int64_t>{3, 6});
}

TEST_CASE("a masked clip gives the same file on 1, 2 and 3 threads, one pair per thread", "[pipeline][piv]") {
  // Pairs run on worker threads and are written in order; masked windows (outside the
  // annulus, on the vane) leave their pixels undeformed. Same bytes for any count.
  testing::TempDir tmp("pivjob");
  vane_bead_clip(tmp / "clip", 192, 160, 8, 20, 7, "png");
  std::vector<std::string> bytes;
  for (int threads : {1, 2, 3}) {
    auto o = job({(tmp / "clip" / "frame_*.png").string()}, tmp / fmt::format("t{}.h5", threads));
    o.centre_x_px = 95.5;
    o.centre_y_px = 79.5;
    o.annulus_inner_px = 0;
    o.annulus_outer_px = 75;
    o.vane.geometry = {4, 5.0, 70.0};
    o.vane.phi0_rad = 0.3;
    o.vane.f_Hz = 0.5;
    o.threads = threads;
    const auto sum = pipeline::run_piv_job(o, {});
    CHECK(sum.pairs == 6);
    CHECK(sum.threads == threads);
    CHECK(sum.pairs_in_parallel == (threads > 1));
    CHECK(sum.masked > 0);
    CHECK(sum.valid > sum.pairs * sum.vectors_per_pair / 3);
    bytes.push_back(testing::read_file(o.output));
  }
  CHECK(bytes[0] == bytes[1]);
  CHECK(bytes[0] == bytes[2]);
  // A single pair runs its windows in parallel instead.
  auto one = job({(tmp / "clip" / "frame_000000.png").string(), (tmp / "clip" / "frame_000001.png").string()},
                 tmp / "one.h5");
  one.threads = 2;
  CHECK_FALSE(pipeline::run_piv_job(one, {}).pairs_in_parallel);
}

TEST_CASE("the vane angle can come from a log, with an offset", "[pipeline][piv]") {
  testing::TempDir tmp("pivjob");
  auto o = clip_job(tmp, 3, "png", tmp / "f.h5");
  testing::write_file(tmp / "log.csv", "# rheometer export\ntime_s,angle_rad\n0,0\n1,0.5\n2,1.0\n");
  o.centre_x_px = 127.5;
  o.centre_y_px = 95.5;
  o.vane.geometry = {4, 4, 60};
  o.vane.log_path = (tmp / "log.csv").string();
  o.vane.log_offset_s = 1.3;
  CHECK(pipeline::run_piv_job(o, {}).masked > 0);
  o.output = tmp / "g.h5";
  o.vane.log_offset_s = 5.0;  // frame times + 5 s lie beyond the log
  CHECK_THROWS_WITH(pipeline::run_piv_job(o, {}), Contains("outside the angle log's range"));
  CHECK_FALSE(fs::exists(tmp / "g.h5"));
}

TEST_CASE("bad PIV inputs are errors that leave no output", "[pipeline][piv]") {
  testing::TempDir tmp("pivjob");
  const auto out = tmp / "v.csv";
  io::write_image(tmp / "a.png", cv::Mat(96, 128, CV_8U, cv::Scalar(10)), false);
  io::write_image(tmp / "b.png", cv::Mat(80, 128, CV_8U, cv::Scalar(10)), false);
  testing::write_file(tmp / "broken.png", "not a png");
  SECTION("mismatched sizes") {
    CHECK_THROWS_WITH(pipeline::run_piv_job(job({(tmp / "a.png").string(), (tmp / "b.png").string()}, out), {}),
                      Contains("b.png: image is 128x80; expected 128x96"));
  }
  SECTION("unreadable file") {
    CHECK_THROWS_WITH(pipeline::run_piv_job(job({(tmp / "a.png").string(), (tmp / "broken.png").string()}, out), {}),
                      Contains("broken.png: not an image"));
  }
  SECTION("zero-frame video") {
    { io::VideoWriter w(tmp / "empty.avi", 25, cv::Size(64, 64), "MJPG"); w.close(); }
    CHECK_THROWS_AS(pipeline::run_piv_job(job({(tmp / "empty.avi").string()}, tmp / "v.h5"), {}),
                    InputError);
    CHECK_FALSE(fs::exists(tmp / "v.h5"));
  }
  SECTION("a mask covering everything") {
    io::write_image(tmp / "mask.png", cv::Mat(96, 128, CV_8U, cv::Scalar(255)), false);
    io::write_image(tmp / "c.png", cv::Mat(96, 128, CV_8U, cv::Scalar(20)), false);
    auto o = job({(tmp / "a.png").string(), (tmp / "c.png").string()}, out);
    o.mask_image = (tmp / "mask.png").string();
    CHECK_THROWS_WITH(pipeline::run_piv_job(o, {}), Contains("mask covers every interrogation window"));
  }
  SECTION("CSV output for a video") {
    CHECK_THROWS_WITH(pipeline::run_piv_job(job({"clip.mp4"}, out), {}),
                      Contains("clip.mp4 is a video (many pairs); a CSV holds one pair"));
  }
  CHECK_FALSE(fs::exists(out));
  for (const auto& name : testing::list_dir(tmp.path())) CHECK(name.find(".partial") == std::string::npos);
}

TEST_CASE("background subtraction frees the vectors from a static pattern", "[pipeline][piv]") {
  testing::TempDir tmp("pivjob");
  // Particles moving by (2.4, -1.1) px per frame under a static bright speckle.
  synth::SynthOptions s;
  s.image.width_px = 192;
  s.image.height_px = 160;
  s.field.u_px = 2.4;
  s.field.v_px = -1.1;
  s.sequence.frames = 8;
  synth::FrameGenerator gen(s);
  synth::SynthOptions st = s;
  st.field.u_px = st.field.v_px = 0;
  st.image.seed = 99;
  st.image.noise = 0;
  st.particles.diameter_px = 4;
  const cv::Mat stat = synth::FrameGenerator(st).next();  // the static pattern
  std::vector<std::string> files;
  for (int k = 0; k < 8; ++k) {
    cv::Mat f = gen.next();
    cv::add(f, stat, f);  // saturating 8-bit add
    const auto p = tmp / fmt::format("f{}.png", k);
    io::write_image(p, f, false);
    files.push_back(p.string());
  }
  auto mean_u = [&](bool background, const std::string& name) {
    auto o = job(files, tmp / name);
    o.preprocess.background = true;
    o.preprocess.background = background;
    pipeline::run_piv_job(o, {});
    const auto u = io::H5File::open_read(tmp / name).read<float>("/pairs/u_px").data;
    double m = 0;
    for (float x : u) m += x;
    return m / u.size();
  };
  const double raw = mean_u(false, "raw.h5"), clean = mean_u(true, "clean.h5");
  INFO("mean u: raw " << raw << ", with background subtraction " << clean);
  CHECK(std::abs(clean - 2.4) < 0.05);
  CHECK(std::abs(raw - 2.4) > std::abs(clean - 2.4));
}

TEST_CASE("a log shifted by 1.3 s is aligned with the video to within one frame", "[pipeline][piv]") {
  testing::TempDir tmp("pivjob");
  vane_bead_clip(tmp / "clip", 256, 192, 10, 20, 30, "png");
  // The rheometer's log: its clock runs 1.3 s ahead of the video's.
  std::string log = "time_s,angle_rad\n";
  for (int k = 0; k <= 500; ++k) {
    const double tau = 0.01 * k;
    log += fmt::format("{},{}\n", tau, 0.3 * std::sin(std::numbers::pi * (tau - 1.3)));
  }
  testing::write_file(tmp / "log.csv", log);
  auto o = job({(tmp / "clip" / "frame_*.png").string()}, tmp / "f.h5");
  o.centre_x_px = 127.5;
  o.centre_y_px = 95.5;
  o.vane.geometry = {4, 5.0, 70.0};
  o.vane.log_path = (tmp / "log.csv").string();
  o.vane.log_offset_auto = true;
  const auto sum = pipeline::run_piv_job(o, {});
  INFO("offset found: " << sum.log_offset_s << " s");
  CHECK(std::abs(sum.log_offset_s - 1.3) < 1.0 / 25.0);
}

// End to end: render an MP4 of beads around an oscillating vane, run PIV on it with
// the vane masked, and compare every pair with the exact field the clip was made of
// (truth.csv holds the field at disp_scale 1; frames.csv the scale of each pair).
TEST_CASE("PIV of a rendered bead clip recovers the field it was made of", "[pipeline][piv]") {
  constexpr double kClipRmsPx = 0.15;  // measured 0.13 px (mp4v compression, 12 px beads, kink at r0)
  testing::TempDir tmp("pivjob");
  const auto s = vane_bead_clip(tmp / "clip", 320, 240, 12, 30, 8, "mp4");
  auto o = job({(tmp / "clip" / "video.mp4").string()}, tmp / "f.h5");
  o.piv.windows_px = {64, 32, 16};
  o.centre_x_px = 159.5;
  o.centre_y_px = 119.5;
  o.vane.geometry = {4, 5.0, 70.0};
  o.vane.phi0_rad = 0.3;
  o.vane.f_Hz = 0.5;
  pipeline::run_piv_job(o, {});

  const auto h = io::H5File::open_read(tmp / "f.h5");
  const auto xs = h.read<double>("/grid/x_px").data, ys = h.read<double>("/grid/y_px").data;
  const auto u = h.read<float>("/pairs/u_px").data, v = h.read<float>("/pairs/v_px").data;
  const auto flag = h.read<std::uint8_t>("/pairs/flag").data;
  const auto frame_a = h.read<std::int64_t>("/pairs/frame_a").data;
  const auto scale = io::read_csv(tmp / "clip" / "frames.csv").numeric_column("disp_scale");
  synth::FieldOptions fo = s.synth.field;
  fo.resolve_centre(320, 240);
  const synth::DisplacementField field(fo);
  double s2 = 0;
  std::size_t n = 0;
  for (std::size_t p = 0; p < frame_a.size(); ++p)
    for (std::size_t i = 0; i < ys.size(); ++i)
      for (std::size_t j = 0; j < xs.size(); ++j) {
        const double x = xs[j], y = ys[i];
        if (x < 32 || y < 32 || x > 287 || y > 207) continue;
        const std::size_t k = (p * ys.size() + i) * xs.size() + j;
        if (flag[k] == 2) continue;  // masked: under the vane
        const auto d = field(x, y);
        const double sc = scale[static_cast<std::size_t>(frame_a[p])];
        s2 += std::pow(u[k] - sc * d[0], 2) + std::pow(v[k] - sc * d[1], 2);
        ++n;
      }
  const double rms = std::sqrt(s2 / n);
  INFO("RMS " << rms << " px over " << n << " vectors in " << frame_a.size() << " pairs");
  CHECK(frame_a.size() == 7);
  CHECK(rms <= kClipRmsPx);
}

// Tracking in the cup: the annulus only bounds where a bead counts (its inner edge at the
// vane's radius has beads on both sides, the ones just outside all in view and the
// fastest), while the vane hides beads (a window stays clear of it in both frames).
TEST_CASE("tracked beads just outside the annulus's inner edge count, none lies near the vane",
          "[pipeline][piv][track]") {
  constexpr double kBeadPx = 16, kInnerPx = 70;
  testing::TempDir tmp("pivjob");
  vane_bead_clip(tmp / "clip", 256, 192, kBeadPx, 20, 4, "png");
  auto o = job({(tmp / "clip" / "frame_*.png").string()}, tmp / "f.h5");
  o.method = pipeline::PairMethod::kTrack;
  o.track.bead_diameter_px = kBeadPx;
  o.centre_x_px = 127.5;
  o.centre_y_px = 95.5;
  o.annulus_inner_px = kInnerPx;
  o.annulus_outer_px = 95;
  o.vane.geometry = {4, 5.0, 70.0};
  o.vane.margin_px = 2.0;
  o.vane.phi0_rad = 0.3;
  o.vane.f_Hz = 0.5;
  o.tracks_output = tmp / "tracks.csv";
  (void)pipeline::run_piv_job(o, {});
  const io::CsvTable t = io::read_csv(o.tracks_output);
  const auto x = t.numeric_column("x_px"), y = t.numeric_column("y_px"), ta = t.numeric_column("t_a_s");
  std::size_t near_edge = 0;
  for (std::size_t k = 0; k < x.size(); ++k) {
    const double r = std::hypot(x[k] - o.centre_x_px, y[k] - o.centre_y_px);
    INFO("bead at (" << x[k] << ", " << y[k] << "), r " << r << " px, t " << ta[k] << " s");
    CHECK(r >= kInnerPx - 1.0);  // its centre pixel inside the annulus
    if (r < kInnerPx + 0.25 * kBeadPx) ++near_edge;
    // A quarter bead clear of the vane (with its margin) at frame a's time.
    const cv::Mat vane = piv::vane_mask({256, 192}, o.centre_x_px, o.centre_y_px,
                                        o.vane.phi0_rad * std::sin(std::numbers::pi * ta[k]), o.vane.geometry,
                                        o.vane.margin_px);
    cv::Mat dist;
    cv::distanceTransform(vane == 0, dist, cv::DIST_L2, cv::DIST_MASK_PRECISE);
    CHECK(dist.at<float>(static_cast<int>(std::lround(y[k])), static_cast<int>(std::lround(x[k]))) >=
          0.25 * kBeadPx - 0.5);
  }
  CHECK(near_edge >= 3);
}
