// shearzone/io/profile_csv.hpp: the radial profile CSV of `shearzone profile` and its
// per-pair companion `<stem>_groups.csv`, written and read here only.
//
// Profile (`profile.csv`): the header block (io/csv.hpp) carries the geometry and the
// choices made (centre_x_px, centre_y_px, m_per_px, Rv_m, R_m, bin_m, f_Hz, t0_s, dt_s,
// fps, groups, n_groups, n_pairs, noise_sigma_m_per_s, N, phi0_rad, ...), then one row
// per radial bin, ascending:
//     r_m                 bin centre (m); bin k covers [Rv + k bin, Rv + (k+1) bin)
//     v_abs_m_per_s       mean |v| over the bin's valid vectors of all selected pairs
//     v_theta_m_per_s     mean azimuthal component (> 0 counter-clockwise as the camera sees it)
//     v_r_m_per_s         mean radial component (outwards > 0)
//     v_abs_rms_m_per_s   RMS of |v|
//     v_abs_sem_m_per_s   bootstrap standard error of the bin mean (empty with one pair)
//     v_noise_m_per_s     noise floor of mean |v| in the bin
//     n_vectors           valid vectors averaged
//     n_masked, n_invalid vectors masked out, vectors rejected by validation
//   lock-in columns (profile/lockin.hpp; empty when the drive phase is unknown or the
//   bin's pairs do not cover the cycle):
//     v_theta_amp_m_per_s, v_theta_amp_se_m_per_s   amplitude of v_theta at the drive
//                         frequency and its standard error
//     v_theta_lag_deg     its phase lag behind the vane's angular velocity
//     v_theta_inphase_m_per_s  the part in phase with the vane's angular velocity
//     v_abs_lockin_m_per_s, v_abs_lockin_se_m_per_s  the mean |v_theta| the fitted
//                         waveform implies, and its standard error
//     v_noise_lockin_m_per_s  the floor of v_abs_lockin (falls like 1/sqrt(n))
//     lockin_n_eff        effective number of independent pairs
//     r_vectors_mean_m    mean radius of the vectors averaged (a grid fills a bin unevenly)
//     r_vectors_sd_m      their standard deviation about it
// A bin without vectors (n_vectors = 0) leaves every velocity cell empty.
//
// Groups (`<stem>_groups.csv`): one row per (pair, bin) with vectors, pair by pair:
//     pair                index of the pair among the selected ones, in time order
//     cycle               oscillation cycle floor(f (t - t0)); empty when f is unknown
//     phase_deg           oscillation phase at the pair's mid-time; empty when f is unknown
//     r_m                 the profile bin's centre (m)
//     phase_span_deg      the drive phase the pair spans (360 f dt); empty when f is unknown
//     v_abs_m_per_s       the pair's mean |v| in the bin
//     v_theta_m_per_s     the pair's mean v_theta in the bin (the lock-in's data)
//     n_vectors           vectors in that mean
// `shearzone width` resamples these for its bootstrap interval.
#pragma once

#include <cstddef>
#include <filesystem>
#include <limits>
#include <ostream>
#include <string>
#include <vector>

#include "shearzone/core/metadata.hpp"
#include "shearzone/core/unset.hpp"

namespace shearzone::io {

/// One bin of a profile. NaN velocities are written as empty cells.
struct ProfileCsvRow {
  double r_m = 0;
  double v_abs = core::kUnset;
  double v_theta = core::kUnset;
  double v_r = core::kUnset;
  double v_abs_rms = core::kUnset;
  double v_abs_sem = core::kUnset;
  double v_noise = 0;
  std::size_t n_vectors = 0, n_masked = 0, n_invalid = 0;
  // Lock-in columns (NaN: none; see above).
  double amp = core::kUnset, amp_se = core::kUnset, lag_deg = core::kUnset, in_phase = core::kUnset;
  double v_abs_lockin = core::kUnset, v_abs_lockin_se = core::kUnset, v_noise_lockin = core::kUnset;
  double n_eff = core::kUnset;
  // The radii of the vectors averaged, m (NaN: no vector, or a file written before the
  // columns existed).
  double r_vectors_mean = core::kUnset, r_vectors_sd = core::kUnset;
  // The velocity fluctuation of v_theta, m/s: as measured, and with the measurement
  // noise removed (NaN: none, or not above the noise).
  double dv_theta_measured = core::kUnset, dv_theta = core::kUnset;
};

/// One (pair, bin) mean of the groups file.
struct ProfileGroupRow {
  static constexpr int kNoCycle = std::numeric_limits<int>::min();  ///< f unknown
  std::size_t pair = 0;
  int cycle = kNoCycle;
  double phase_deg = core::kUnset;  ///< NaN when f is unknown
  double phase_span_deg = 0;        ///< 0 when unknown
  double r_m = 0, v_abs = 0, n_vectors = 0;
  double v_theta = core::kUnset;    ///< NaN in files written before the column existed
  std::size_t line = 0;  ///< source line (reading only)
};

/// What `width` reads back from a profile: r_m, v_abs_m_per_s, v_noise_m_per_s and
/// n_vectors of every row, v_abs_lockin_m_per_s and v_noise_lockin_m_per_s when present
/// (`has_lockin`), r_vectors_mean_m and r_vectors_sd_m when present (`has_vector_radii`;
/// the other columns are not needed and may be absent; they are left NaN
/// or 0), and the header block.
struct ProfileCsv {
  std::filesystem::path path;
  core::Metadata metadata;
  std::vector<ProfileCsvRow> rows;
  bool has_vector_radii = false;  ///< r_vectors_mean_m / r_vectors_sd_m present
  bool has_lockin = false;  ///< the lock-in columns exist and hold at least one value
  /// A header value, "" when absent.
  std::string meta(const std::string& key) const;
  /// A header value as a number, NaN when absent or not a number.
  double meta_number(const std::string& key) const;
};

/// `<stem>_groups.csv` beside `profile`.
std::filesystem::path profile_groups_path(const std::filesystem::path& profile);

void write_profile_csv(std::ostream& out, const core::Metadata& metadata, const std::vector<ProfileCsvRow>& rows);
/// Writes `metadata`, then the descriptions of pair, cycle and phase_deg, then the rows.
void write_profile_groups_csv(std::ostream& out, const core::Metadata& metadata,
                              const std::vector<ProfileGroupRow>& rows);

/// Reads a profile; InputError (file, line, column, value) for a missing column, a bad
/// number, a count that is not a whole number >= 0, a bin with vectors but no v_abs, or
/// a file without rows.
ProfileCsv read_profile_csv(const std::filesystem::path& path);
/// Reads a groups file; InputError for a pair index that is not a whole number below 1e8
/// or rows that do not come pair by pair (pair indices 0, 1, 2, ... without gaps). A
/// pair's cycle and phase are read from its first row (later rows keep kNoCycle).
std::vector<ProfileGroupRow> read_profile_groups_csv(const std::filesystem::path& path);

}  // namespace shearzone::io
