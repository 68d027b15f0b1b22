// shearzone/io/field_file.hpp: PIV vector fields on disk, written by `shearzone piv`
// and read by `shearzone profile` (and by anyone else) through this file only.
//
// One pair, CSV (`vectors.csv`): the header block of io/csv.hpp (every option and
// convention, plus frame_a, frame_b, t_a_s, dt_s), then one row per grid node, row by
// row (y outer, x inner):
//     x_px, y_px        node position (pixel centres at integers, y downwards)
//     u_px, v_px        displacement from frame a to frame b, px per pair
//     flag              valid | replaced | masked | invalid
//     peak, peak_ratio  correlation peak height and primary/secondary peak ratio
//
// Any number of pairs, HDF5 (`fields.h5`):
//     /grid/x_px [nx], /grid/y_px [ny]                        float64, px
//     /pairs/u_px, v_px, peak, peak_ratio [npairs, ny, nx]    float32, px per pair
//     /pairs/flag [npairs, ny, nx]                            uint8: 0 valid, 1 replaced,
//                                                             2 masked, 3 invalid
//                                                             (attribute "mapping")
//     /pairs/frame_a, frame_b [npairs]                        int64 source frame indices
//     /pairs/t_a_s, dt_s [npairs]                             float64 times, s
//     root attributes: fps, source, options, conventions, shearzone_version,
//     duplicates_skipped, damaged_frames_skipped, damaged_frames, centre_x_px and
//     centre_y_px (when known), calibration and experiment tags (m_per_px, f_Hz, phi0_rad,
//     N, ...) and free `--attr` pairs.
// Pairs are appended one at a time (the file never holds a whole clip in memory) and
// read back one at a time.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <ostream>
#include <string>
#include <vector>

#include "shearzone/core/metadata.hpp"
#include "shearzone/core/point_vectors.hpp"
#include "shearzone/core/vector_field.hpp"
#include "shearzone/io/hdf5.hpp"

namespace shearzone::io {

class H5File;

/// True for a path ending in .csv (any case): a one-pair field.
bool is_field_csv(const std::filesystem::path& path);

/// Writes one field as the one-pair CSV.
void write_field_csv(std::ostream& out, const core::Metadata& metadata, const core::VectorField& field);

/// Appends pairs to a new field file. The file is created with the first pair (its grid
/// fixes the grid of the file); write it at io::AtomicOutput::temp_path() and commit
/// after close().
class FieldFileWriter {
 public:
  explicit FieldFileWriter(std::filesystem::path path);
  ~FieldFileWriter();
  FieldFileWriter(FieldFileWriter&&) noexcept;
  FieldFileWriter& operator=(FieldFileWriter&&) noexcept;

  void append(const core::VectorField& field, std::int64_t frame_a, std::int64_t frame_b, double t_a_s,
              double dt_s);
  /// True once a pair has been appended (the file exists).
  bool started() const { return h5_ != nullptr; }
  void set_attribute(const std::string& name, double value);
  void set_attribute(const std::string& name, std::int64_t value);
  void set_attribute(const std::string& name, const std::string& value);
  void set_attribute(const std::string& name, const char* value) { set_attribute(name, std::string(value)); }
  void close();

 private:
  std::filesystem::path path_;
  std::unique_ptr<H5File> h5_;
};

/// Pairs of displacements at points: a field file's grids (FieldReader) or a tracks
/// file's beads (io/track_file.hpp, open_pair_file).
class PairReader {
 public:
  virtual ~PairReader() = default;
  virtual std::size_t size() const = 0;
  /// Pair k: its displacements and time (t_a, dt). Every measured (valid or replaced)
  /// vector is finite, else InputError naming dataset, pair and point.
  virtual void read_points(std::size_t k, core::PointVectors& points, double& t_a_s, double& dt_s) = 0;
  /// A numeric root attribute (CSV: header value), NaN if absent or not a number.
  virtual double attribute(const std::string& name) const = 0;
  /// A root attribute as text (numbers formatted), "" if absent.
  virtual std::string text_attribute(const std::string& name) const = 0;
  /// True for tracked beads (one vector per bead), false for a grid.
  virtual bool beads() const { return false; }
};

/// Pairs from a field file: an HDF5 clip (streamed) or one CSV pair.
class FieldReader : public PairReader {
 public:
  /// Pair k: the field and its time (t_a, dt), checked as read_points.
  virtual void read(std::size_t k, core::VectorField& field, double& t_a_s, double& dt_s) = 0;
  /// The grid's nodes, row by row (core::to_points).
  void read_points(std::size_t k, core::PointVectors& points, double& t_a_s, double& dt_s) override;

 private:
  core::VectorField grid_;
};

/// Opens a field file. HDF5: every dataset above must be there, with sizes the file
/// really holds and that fit the memory budget (io/hdf5.hpp). CSV: one pair on a
/// regular grid; `csv_dt_s` is its time step (the CSV does not carry a usable one).
std::unique_ptr<FieldReader> open_field_file(const std::filesystem::path& path, double csv_dt_s);
/// The same for an HDF5 field file already open (open_pair_file looks inside first).
std::unique_ptr<FieldReader> open_field_file(H5File h5, const std::filesystem::path& path);

}  // namespace shearzone::io
