// Tracked beads on disk (io/track_file.hpp): HDF5 written pair by pair and read back,
// the CSV's columns and empty cells.
#include <cmath>
#include <limits>
#include <string>

#include <catch2/catch.hpp>

#include "shearzone/core/error.hpp"
#include "shearzone/core/unset.hpp"
#include "shearzone/io/hdf5.hpp"
#include "shearzone/io/track_file.hpp"
#include "support/temp_dir.hpp"

using namespace shearzone;
using Catch::Matchers::Contains;

namespace {

core::TrackedBeads rows(std::int64_t first_id, std::int64_t frame, std::size_t n) {
  core::TrackedBeads t;
  for (std::size_t k = 0; k < n; ++k) {
    t.track_id.push_back(first_id + static_cast<std::int64_t>(k));
    t.frame_a.push_back(frame);
    t.frame_b.push_back(frame + 1);
    t.t_a_s.push_back(0.04 * static_cast<double>(frame));
    t.dt_s.push_back(0.04);
    t.x_px.push_back(10.25 + static_cast<double>(k));
    t.y_px.push_back(20.5);
    const bool ok = k % 2 == 0;
    t.u_px.push_back(ok ? 0.125 : std::numeric_limits<double>::quiet_NaN());
    t.v_px.push_back(ok ? -0.5 : std::numeric_limits<double>::quiet_NaN());
    t.fb_px.push_back(ok ? 0.01 : std::numeric_limits<double>::quiet_NaN());
    t.tracked.push_back(ok ? 1 : 0);
    t.linked.push_back(frame > 0 ? 1 : 0);
  }
  return t;
}

}  // namespace

TEST_CASE("tracks file: HDF5 rows appended pair by pair read back exactly, with the counts", "[io][tracks]") {
  testing::TempDir dir("tracks_h5");
  const auto path = dir / "tracks.h5";
  {
    io::TrackFileWriter w(path, {{"pair_method", "track"}});
    w.append(rows(0, 0, 3));
    w.append(core::TrackedBeads{});  // a pair without beads
    w.append(rows(0, 1, 5000));      // more than a chunk
    w.close();
  }
  std::string options;
  const core::TrackedBeads t = io::read_track_file(path, &options);
  REQUIRE(t.size() == 5003);
  CHECK(t.track_id[3] == 0);
  CHECK(t.frame_a[3] == 1);
  CHECK(t.x_px[4] == 11.25);
  CHECK(t.u_px[0] == 0.125);
  CHECK(std::isnan(t.u_px[1]));
  CHECK(t.tracked[1] == 0);
  CHECK(t.linked[3] == 1);
  CHECK_THAT(options, Contains("pair_method: track"));
  const io::H5File h5 = io::H5File::open_read(path);
  CHECK(h5.attribute_int("/", "beads") == 5003);
  CHECK(h5.attribute_int("/", "tracks") == 5000);
  CHECK_THAT(h5.attribute_string("/", "conventions"), Contains("y down"));
}

TEST_CASE("tracks file: the CSV has units in its columns, the velocity, and empty cells for what is not measured",
          "[io][tracks]") {
  testing::TempDir dir("tracks_csv");
  const auto path = dir / "beads.csv";
  {
    io::TrackFileWriter w(path, {{"pair_method", "track"}});
    w.append(rows(7, 2, 2));
    w.close();
  }
  const std::string s = testing::read_file(path);
  CHECK_THAT(s, Contains("# pair_method: track"));
  CHECK_THAT(s, Contains("# convention_image_axes:"));
  CHECK_THAT(s, Contains("track_id,frame_a,frame_b,t_a_s,dt_s,x_px,y_px,u_px,v_px,vx_px_per_s,vy_px_per_s,fb_px,"
                         "tracked,linked\n"));
  CHECK_THAT(s, Contains("7,2,3,0.08,0.04,10.25,20.5,0.125,-0.5,3.125,-12.5,0.01,1,1\n"));
  CHECK_THAT(s, Contains("8,2,3,0.08,0.04,11.25,20.5,,,,,,0,1\n"));
}

TEST_CASE("tracks file: a file without the beads' columns is refused with the file and the dataset", "[io][tracks]") {
  testing::TempDir dir("tracks_bad");
  const auto path = dir / "other.h5";
  {
    io::H5File h5 = io::H5File::create(path);
    const std::vector<std::int64_t> ids{1, 2};
    h5.write("/beads/track_id", {2}, ids);
    h5.close();
  }
  CHECK_THROWS_WITH(io::read_track_file(path), Contains("other.h5") && Contains("/beads/frame_a"));
}

TEST_CASE("tracks file: a corrupt heap that declares 16 GB is refused, not allocated", "[io][tracks]") {
  // Found by fuzz_track_h5: one bit of a 40 kB tracks file made HDF5 ask for 17 179 869 360 bytes.
  const auto path = std::filesystem::path(SHEARZONE_TEST_DATA_DIR) / "regressions" / "h5_tracks_local_heap_16gb.h5";
  CHECK_THROWS_WITH(io::read_track_file(path), Contains("h5_tracks_local_heap_16gb.h5") &&
                                                   Contains("local heap at byte 1384 declares 17179869360 bytes"));
}

TEST_CASE("tracks file: a heap whose reserved bytes are set is checked as any other heap", "[io][tracks]") {
  // Found by fuzz_track_h5 (CI's seed corpus, 2 minutes): the heap at byte 1384 with its
  // reserved bytes 0x3b and its size 16 GiB. HDF5 ignores those bytes; the heap check
  // once skipped such a heap, and HDF5 asked for 17 179 869 360 bytes.
  const auto path = std::filesystem::path(SHEARZONE_TEST_DATA_DIR) / "regressions" / "h5_tracks_heap_reserved_bytes.h5";
  CHECK_THROWS_WITH(io::read_track_file(path), Contains("h5_tracks_heap_reserved_bytes.h5") &&
                                                   Contains("local heap at byte 1384 declares 17179869360 bytes"));
}

TEST_CASE("tracks file: an unfiltered chunk shorter than its chunk is refused, not read past its end", "[io][tracks]") {
  // Found by fuzz_track_h5: the deflate message of /beads/t_a_s lost, its 187-byte chunk
  // was copied as the 32 kB chunk it declares (a heap overflow inside HDF5 1.10).
  const auto path = std::filesystem::path(SHEARZONE_TEST_DATA_DIR) / "regressions" / "h5_tracks_chunk_short.h5";
  CHECK_THROWS_WITH(io::read_track_file(path), Contains("h5_tracks_chunk_short.h5") && Contains("/beads/t_a_s") &&
                                                   Contains("holds 187 bytes, 32768 expected"));
}

TEST_CASE("tracks file: a chunk shape of 128 MiB is refused before HDF5 allocates it", "[io][tracks]") {
  // The CI fuzz run's out-of-memory: HDF5 allocates and fills a whole chunk however few
  // rows the dataset has. Made with h5py from synth_beads_16px.h5, /beads/t_a_s
  // rewritten with chunks of 2^24 doubles (deflated to 130 kB).
  const auto path = std::filesystem::path(SHEARZONE_TEST_DATA_DIR) / "regressions" / "h5_tracks_chunk_128mib.h5";
  CHECK_THROWS_WITH(io::read_track_file(path), Contains("h5_tracks_chunk_128mib.h5") && Contains("/beads/t_a_s") &&
                                                   Contains("chunks of 128 MiB, above 64 MiB"));
}

TEST_CASE("tracks file as pairs for profile: a pair per frame_a, tracked beads at their midpoints", "[io][tracks]") {
  testing::TempDir dir("tracks_pairs");
  const auto path = dir / "tracks.h5";
  {
    io::TrackFileWriter w(path, {{"pair_method", "track"}});
    w.set_attribute("m_per_px", 2e-4);
    w.append(rows(0, 0, 3));
    w.append(core::TrackedBeads{});  // no row: not a pair of the file
    w.append(rows(0, 2, 4));
    w.close();
  }
  const auto pairs = io::open_pair_file(path, core::kUnset);
  REQUIRE(pairs->beads());
  REQUIRE(pairs->size() == 2);
  CHECK(pairs->attribute("m_per_px") == 2e-4);
  core::PointVectors p;
  double t_a = 0, dt = 0;
  pairs->read_points(1, p, t_a, dt);
  REQUIRE(p.size() == 4);
  CHECK(t_a == 0.08);
  CHECK(dt == 0.04);
  // Bead 0 tracked: (10.25, 20.5) + (0.125, -0.5) / 2; bead 1 not: invalid at its centre.
  CHECK(p.x_px[0] == 10.3125);
  CHECK(p.y_px[0] == 20.25);
  CHECK(p.u_px[0] == 0.125);
  CHECK(p.flag[0] == core::VectorFlag::kValid);
  CHECK(p.x_px[1] == 11.25);
  CHECK(p.flag[1] == core::VectorFlag::kInvalid);
}

TEST_CASE("tracks file as pairs: rows out of time order or a tracked bead without a value are refused",
          "[io][tracks]") {
  testing::TempDir dir("tracks_pairs_bad");
  const auto path = dir / "tracks.h5";
  {
    io::TrackFileWriter w(path, {});
    w.append(rows(0, 5, 2));
    w.append(rows(2, 3, 2));
    w.close();
  }
  CHECK_THROWS_WITH(io::open_pair_file(path, core::kUnset),
                    Contains("tracks.h5") && Contains("/beads row 2: frame_a 3 after 5"));
  const auto nan_path = dir / "nan.h5";
  {
    core::TrackedBeads t = rows(0, 0, 2);
    t.tracked[1] = 1;  // its displacement is NaN
    io::TrackFileWriter w(nan_path, {});
    w.append(t);
    w.close();
  }
  const auto pairs = io::open_pair_file(nan_path, core::kUnset);
  core::PointVectors p;
  double t_a = 0, dt = 0;
  CHECK_THROWS_WITH(pairs->read_points(0, p, t_a, dt),
                    Contains("nan.h5") && Contains("/beads row 1") && Contains("needs a finite centre and displacement"));
}

TEST_CASE("tracks file as pairs: rows of one pair with different times are refused", "[io][tracks]") {
  testing::TempDir dir("tracks_pairs_times");
  const auto path = dir / "times.h5";
  {
    core::TrackedBeads t = rows(0, 4, 3);
    t.dt_s[2] = 0.08;  // the same frame_a, another time step
    io::TrackFileWriter w(path, {});
    w.append(t);
    w.close();
  }
  CHECK_THROWS_WITH(io::open_pair_file(path, core::kUnset),
                    Contains("times.h5") && Contains("/beads row 2") && Contains("differ from the row before"));
}
