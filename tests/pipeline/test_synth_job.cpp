#include <catch2/catch.hpp>

#include "shearzone/core/error.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/io/image.hpp"
#include "shearzone/io/video.hpp"
#include "shearzone/pipeline/synth_job.hpp"
#include "support/temp_dir.hpp"

using namespace shearzone;
using Catch::Matchers::Contains;

namespace {
pipeline::SynthJobOptions small_job(const std::filesystem::path& dir) {
  pipeline::SynthJobOptions j;
  j.synth.image.width_px = 96;
  j.synth.image.height_px = 64;
  j.synth.field.u_px = 2.25;
  j.synth.field.v_px = -1.5;
  j.out_dir = dir;
  return j;
}
}  // namespace

TEST_CASE("a synth pair writes A, B, truth and frame times", "[pipeline]") {
  testing::TempDir tmp("job");
  const auto out = tmp / "pair";
  const auto summary = pipeline::run_synth_job(small_job(out), core::standard_metadata("test"));
  CHECK(testing::list_dir(out) ==
        std::vector<std::string>{"A.png", "B.png", "frames.csv", "truth.csv"});
  CHECK(summary.frames == 2);
  CHECK(summary.tracers > 0);
  const auto truth = io::read_csv(out / "truth.csv");
  CHECK(truth.columns == std::vector<std::string>{"x_px", "y_px", "u_px", "v_px"});
  CHECK(truth.numeric_column("u_px").front() == 2.25);
  CHECK(truth.numeric_column("v_px").back() == -1.5);
  CHECK(truth.numeric_column("x_px").front() == 7.5);  // centre of the first 16x16 block
  CHECK(core::metadata_value(truth.metadata, "command_line") == "test");
  CHECK(core::metadata_value(truth.metadata, "seed") == "1");
  CHECK(io::read_image_gray(out / "A.png").size() == cv::Size(96, 64));
}

TEST_CASE("a synth sequence can be written as MP4", "[pipeline]") {
  testing::TempDir tmp("job");
  auto job = small_job(tmp / "clip");
  job.synth.sequence.frames = 6;
  job.format = "mp4";
  pipeline::run_synth_job(job, {});
  CHECK(testing::list_dir(tmp / "clip") ==
        std::vector<std::string>{"frames.csv", "truth.csv", "video.mp4"});
  io::VideoReader r(tmp / "clip" / "video.mp4");
  CHECK(r.info().frame_count == 6);
  CHECK(io::read_csv(tmp / "clip" / "frames.csv").num_rows() == 6);
}

TEST_CASE("a failing synth job writes nothing", "[pipeline]") {
  testing::TempDir tmp("job");
  auto job = small_job(tmp / "bad");
  job.format = "mp4";
  job.synth.image.bit_depth = 16;
  CHECK_THROWS_WITH(pipeline::run_synth_job(job, {}), Contains("8-bit frames only"));
  CHECK(testing::list_dir(tmp.path()).empty());
}

TEST_CASE("a synth job refuses to overwrite without force", "[pipeline]") {
  testing::TempDir tmp("job");
  auto job = small_job(tmp.path());
  pipeline::run_synth_job(job, {});
  const std::string before = testing::read_file(tmp / "A.png");
  job.synth.image.seed = 2;  // different content
  CHECK_THROWS_WITH(pipeline::run_synth_job(job, {}), Contains("A.png: output exists"));
  CHECK(testing::read_file(tmp / "A.png") == before);
  job.force = true;
  pipeline::run_synth_job(job, {});
  CHECK(testing::read_file(tmp / "A.png") != before);
}
