// shearzone/sim/sim_io.hpp: the simulator's files (docs/formats.md, "Sim outputs"):
// checkpoints of the full World state in HDF5, snapshot series in HDF5 with an XDMF
// index for ParaView, and the per-step diagnostics CSV. Writing goes through
// shearzone/io (H5File, CsvWriter); atomicity is the caller's business (write to
// AtomicOutput::temp_path()).
//
// Checkpoint layout (format "shearzone-sim-checkpoint", format_version 2; version 1
// files, without orientations, still read), float64
// unless stated; a group is absent when its count is 0:
//     /                 attributes: format, format_version, step, iteration_cap_hits,
//                       time_s, n_bodies, n_walls, n_ropes, n_angles, n_contacts,
//                       option_* (every sim::Options field, SI units), and the
//                       caller's metadata as string attributes
//     /bodies/position [n,3] m, velocity [n,3] m/s, angular_velocity [n,3] rad/s,
//             orientation [n,4] unit quaternion (w, x, y, z), diameter [n] m, mass [n] kg, inertia [n] kg m², kind [n] uint8
//             (0 mobile, 1 fixed, 2 kinematic)
//     /walls/point [w,3], normal [w,3], friction [w]
//     /ropes/bodies [r,2] int64, max_length [r] m, impulse [r] N s
//     /angles/bodies [a,3] int64 (prev, mid, next), max_angle [a] rad, impulse [a] N s m
//     /contacts/bodies [c,3] int64 (i or −1, wall or −1, j), normal [c,3], gap [c] m,
//             normal_impulse [c] N s, tangential_impulse [c,3] N s, status [c] uint8
// Every double is stored as IEEE binary64, so read_checkpoint(write_checkpoint(w))
// rebuilds w exactly: World::from_state continues bit-identically (same state_hash()).
//
// Snapshot file (one HDF5 file, appendable datasets, float64):
//     /time_s [S], /step [S] int64, /position [S,n,3] m, /velocity [S,n,3] m/s,
//     /angular_velocity [S,n,3] rad/s; static: /diameter [n] m, /chain_id [n] int64,
//     /kind [n] uint8
// and its XDMF 2 index (write_snapshot_xdmf): a Temporal collection of Polyvertex
// grids whose Geometry (XYZ) and attributes (velocity, angular_velocity, diameter,
// chain_id, kind) point into the HDF5 file, per snapshot through a HyperSlab.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <ostream>
#include <string>
#include <vector>

#include "shearzone/core/metadata.hpp"
#include "shearzone/sim/world.hpp"

namespace shearzone::io {
class H5File;
class CsvWriter;
}  // namespace shearzone::io

namespace shearzone::sim {

/// Writes the full state of `world` to a new HDF5 file at `path` (truncating).
void write_checkpoint(const std::filesystem::path& path, const World& world,
                      const core::Metadata& metadata = {});
/// Reads a checkpoint; InputError naming the file for a missing or malformed one.
WorldState read_checkpoint(const std::filesystem::path& path);

/// Chain id per body: the connected components of the rope graph, numbered 0, 1, ...
/// in the order of their smallest body index (a body without ropes is a chain of one).
std::vector<std::int64_t> chain_ids_from_ropes(const WorldState& state);

/// Appends snapshots of a World to an HDF5 file (see the layout above).
class SnapshotWriter {
 public:
  /// Creates the file; the body count, diameters, kinds and chain ids are those of
  /// `world` now (chain_ids empty: chain_ids_from_ropes). Throws ConfigError if
  /// chain_ids has the wrong length.
  SnapshotWriter(const std::filesystem::path& path, const World& world,
                 const core::Metadata& metadata = {}, std::vector<std::int64_t> chain_ids = {});
  ~SnapshotWriter();
  SnapshotWriter(const SnapshotWriter&) = delete;
  SnapshotWriter& operator=(const SnapshotWriter&) = delete;

  /// Appends the current positions and velocities of `world` (same body count).
  void append(const World& world);
  /// Flushes and closes the file (InputError on a write failure).
  void close();

  [[nodiscard]] std::size_t snapshot_count() const { return steps_.size(); }
  [[nodiscard]] std::size_t body_count() const { return n_; }
  [[nodiscard]] const std::vector<double>& times() const { return times_; }
  [[nodiscard]] const std::vector<std::int64_t>& steps() const { return steps_; }

 private:
  std::unique_ptr<io::H5File> file_;
  std::size_t n_ = 0;
  std::vector<double> times_;
  std::vector<std::int64_t> steps_;
  std::vector<double> buffer_;
};

/// Writes the XDMF 2 index of a snapshot file holding `times.size()` snapshots of
/// `body_count` bodies; `h5_name` is the HDF5 file name as the XDMF refers to it
/// (relative to the XDMF file's folder).
void write_snapshot_xdmf(std::ostream& out, const std::string& h5_name, std::size_t body_count,
                         const std::vector<double>& times);

/// The diagnostics CSV: one row per step. Columns (units in the names):
/// step, time_s, iterations, residual, cap_hit, contacts, active_contacts,
/// sliding_contacts, sticking_contacts, active_ropes, active_angles, max_overlap_over_d,
/// max_rope_excess_over_d, max_angle_excess_rad, kinetic_energy_J, row_updates,
/// active_row_updates, frozen_skips, rows (the StepDiagnostics fields of the same names:
/// local solves, those on rows in contact or loaded, row visits skipped as frozen, rows of
/// the step).
class DiagnosticsCsv {
 public:
  DiagnosticsCsv(std::ostream& out, const core::Metadata& metadata);
  ~DiagnosticsCsv();
  DiagnosticsCsv(const DiagnosticsCsv&) = delete;
  DiagnosticsCsv& operator=(const DiagnosticsCsv&) = delete;
  void row(const StepDiagnostics& d, double time_s);
  static const std::vector<std::string>& columns();

 private:
  std::unique_ptr<io::CsvWriter> csv_;
};

}  // namespace shearzone::sim
