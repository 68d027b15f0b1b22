// shearzone/pipeline/profile_job.hpp: `shearzone profile`.
//
// A PIV field file (HDF5 clip in the layout of `shearzone piv`, or a single-pair CSV)
// -> radial profile CSV plus a companion `<stem>_groups.csv` with the mean |v| per
// pair and bin, which `width` (pipeline/width_job.hpp) resamples for its bootstrap;
// both layouts in io/profile_csv.hpp.
#pragma once

#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "shearzone/core/metadata.hpp"
#include "shearzone/core/progress.hpp"
#include "shearzone/core/unset.hpp"

namespace shearzone::pipeline {

/// Relative disagreement between two scale sources above which profile refuses.
inline constexpr double kScaleTolerance = 0.01;

struct ProfileJobOptions {
  std::filesystem::path input;   ///< fields .h5 or a single-pair .csv
  std::filesystem::path output;  ///< profile .csv
  bool force = false;
  // Geometry (px). Priority: given here > field-file attributes > detection.
  double centre_x_px = core::kUnset, centre_y_px = core::kUnset;
  double vane_radius_px = core::kUnset;  ///< R_v: first bin edge (0 when unknown)
  double cup_radius_px = core::kUnset;   ///< R: last bin edge
  std::string detect_cup_frame;    ///< image (or video: first frame) to find the rim in
  double detect_min_radius_px = core::kUnset, detect_max_radius_px = core::kUnset;
  // Calibration. Up to three sources of the scale: m_per_px (--m-per-px), the cup
  // radius cup_radius_m / R_px (--cup-radius-m with R in px from --radii-px, the
  // file or the rim detection), and the field file's m_per_px attribute. One source:
  // it is used. Two or more that disagree by more than kScaleTolerance: ConfigError
  // naming both, unless scale_from names the one to use ("m-per-px", "cup-radius",
  // "file"); sources that agree: the first in that order.
  double m_per_px = core::kUnset;
  double cup_radius_m = core::kUnset;
  std::string scale_from;  ///< "", "m-per-px", "cup-radius" or "file"
  // Bins. Priority: bin_m > bin_px > bead_diameter_m / 2.
  double bin_m = core::kUnset, bin_px = core::kUnset;
  double bead_diameter_m = 2.4e-3;  ///< the paper's steel beads
  bool exclude_replaced = false;
  // Pair selection (needs f: given or attribute f_Hz) and the drive phase.
  double f_Hz = core::kUnset;
  /// Time of an upward zero crossing of phi(t), s. The drive phase comes from, in this
  /// order: an angle log (`log_path`: phi0 sin(2 pi f (t - t0)) + c fitted to it by
  /// least squares, f refined; log time = field time + log_offset_s, default the
  /// file's vane_log_offset_s, else 0), t0_s when set, the file's vane_phase_rad
  /// (t0 = -phase / (2 pi f), written by `piv` for its vane mask), else t0 = 0 (an
  /// assumption, said in the header).
  double t0_s = core::kUnset;
  std::string log_path;          ///< angle log CSV (time_s, angle_rad)
  double log_offset_s = core::kUnset;
  /// Lock-in estimator (profile/lockin.hpp): highest odd harmonic H, 0 = off. It runs
  /// when the drive phase is known and no phase window or phase bins are selected. H is
  /// lowered (odd) until the pairs support it: at least 4 (H + 2) pairs, and
  /// H f dt <= 1/4 (at least four pairs per period of the highest harmonic).
  int lockin_harmonics = 7;
  std::vector<int> cycles;       ///< empty: all
  double phase_min_deg = 0.0, phase_max_deg = 360.0;
  /// Phase-resolved profiles: K equal phase bins over the phase range, one output
  /// `<stem>_phaseKK.csv` each (0: one profile over the whole range).
  int phase_bins = 0;
  /// What standard errors and the r_c bootstrap resample: "auto" (cycles when at
  /// least 8 hold data, else pairs), "cycles" or "pairs" (profile/resample.hpp).
  std::string groups = "auto";
  double dt_s = core::kUnset;          ///< pair time step of a CSV field (required there)
  // Noise floor: a static reference field file, or a region (m); default: the
  // outer 15 % of the annulus.
  std::filesystem::path noise_ref;
  double noise_min_m = core::kUnset, noise_max_m = core::kUnset;
  void validate() const;
};

struct ProfileJobSummary {
  std::size_t pairs_read = 0, pairs_used = 0, groups = 0, bins = 0;
  double centre_x_px = 0, centre_y_px = 0, m_per_px = 0, R_m = 0, Rv_m = 0, bin_m = 0;
  double noise_floor_m_per_s = 0;
  std::string geometry_source, scale_source, grouping;
  double rho = 0;
  std::string drive_phase_source;  ///< where t0 came from ("" when f is unknown)
  double t0_s = core::kUnset;
  bool lockin = false;             ///< lock-in columns written
};

ProfileJobSummary run_profile_job(const ProfileJobOptions& options, const core::Metadata& header,
                                  const core::ProgressCallback& progress = {});

}  // namespace shearzone::pipeline
