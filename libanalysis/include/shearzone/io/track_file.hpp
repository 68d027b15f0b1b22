// shearzone/io/track_file.hpp: tracked beads on disk (`piv --method track --tracks
// FILE`), one row per bead detected in a pair's frame a (core/tracked_beads.hpp),
// written and read through this file only.
//
// HDF5 (`tracks.h5`):
//     /beads/track_id, frame_a, frame_b [n]           int64
//     /beads/t_a_s, dt_s [n]                          float64, s
//     /beads/x_px, y_px [n]                           float64, the centre in frame a, px
//     /beads/u_px, v_px [n]                           float64, displacement a -> b, px
//                                                     (NaN where not tracked)
//     /beads/fb_px [n]                                float64, forward-backward distance, px
//     /beads/tracked, linked [n]                      uint8 (1 / 0)
//     root attributes: options (the header, `key: value` lines), conventions,
//     shearzone_version, beads, tracks, and the caller's own (set_attribute: `piv`
//     writes those of its field file, centre, scale, drive and tags included).
// CSV (`beads.csv`): the header block of io/csv.hpp, then one row per bead with the
// columns above and the velocity vx_px_per_s, vy_px_per_s = (u, v) / dt; a value that
// is not defined (NaN) is an empty cell.
//
// Rows are appended pair by pair: a clip's tracks are never held in memory whole.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <ostream>
#include <string>

#include "shearzone/core/metadata.hpp"
#include "shearzone/core/tracked_beads.hpp"
#include "shearzone/io/field_file.hpp"

namespace shearzone::io {

class H5File;
class CsvWriter;

/// True for a path ending in .h5 or .csv (any case): a tracks file these write.
bool is_track_file_path(const std::filesystem::path& path);

class TrackFileWriter {
 public:
  /// Creates `path` (write it at io::AtomicOutput::temp_path(), commit after close()):
  /// HDF5 for .h5, CSV for .csv; `header` goes into the CSV's header block or the HDF5
  /// attribute "options".
  TrackFileWriter(const std::filesystem::path& path, const core::Metadata& header);
  ~TrackFileWriter();
  TrackFileWriter(const TrackFileWriter&) = delete;
  TrackFileWriter& operator=(const TrackFileWriter&) = delete;

  void append(const core::TrackedBeads& rows);
  /// Root attributes, as a field file's (HDF5 only; a CSV's header is written first).
  void set_attribute(const std::string& name, std::int64_t value);
  void set_attribute(const std::string& name, double value);
  void set_attribute(const std::string& name, const std::string& value);
  void set_attribute(const std::string& name, const char* value) { set_attribute(name, std::string(value)); }
  /// Writes the counts (HDF5 attributes beads, tracks) and closes.
  void close();

 private:
  bool csv_;
  std::int64_t rows_ = 0, max_id_ = -1;
  std::unique_ptr<H5File> h5_;
  std::unique_ptr<std::ofstream> file_;
  std::unique_ptr<CsvWriter> csv_writer_;
};

/// Reads an HDF5 tracks file whole (its size checked against the memory budget,
/// io/hdf5.hpp); InputError naming the file and dataset where one is missing or the
/// columns differ in length. `options` receives the header text when not null.
core::TrackedBeads read_track_file(const std::filesystem::path& path, std::string* options = nullptr);

/// Opens the pairs of a tracks file (HDF5 with /beads) or else a field file
/// (io/field_file.hpp). A tracks file's pair is the rows of one frame_a, in the order
/// written (a pair without a bead has no row, and so does not appear); a tracked bead is
/// one valid vector at the midpoint of its displacement (x + u/2, y + v/2), where the
/// chord of a circular path is tangential; a bead not tracked is an invalid vector at its
/// centre. InputError for rows out of time order or a tracked bead without a finite value.
std::unique_ptr<PairReader> open_pair_file(const std::filesystem::path& path, double csv_dt_s);

}  // namespace shearzone::io
