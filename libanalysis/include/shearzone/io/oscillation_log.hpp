// shearzone/io/oscillation_log.hpp: rheometer oscillation logs (drive and response
// waveforms) from generic CSV/TSV, Anton Paar RheoCompass and TA TRIOS text exports,
// and RepTate .laos files, in SI units.
//
// A log holds one or more segments (RheoCompass "Interval data:" blocks, TRIOS step
// blocks, or the values of an interval column of a generic table); each segment is
// one drive amplitude or a sweep that the laos stage splits further. Two quantities:
//   angle/torque   the vane's deflection angle (rad) and torque (N m), the default;
//   strain/stress  dimensionless strain and stress (Pa), for data the instrument
//                  already converted (`--strain COL --stress COL`).
// Time (s) is optional: loggers triggered every delta-phi record no time.
//
// Errors are InputError naming the file and the line (and column): a NaN or missing
// cell, a unit that is not known, a time that does not increase, an encoding that
// cannot be read. Nothing is interpreted silently: a column that cannot be found is an
// error listing the columns that are there.
#pragma once

#include <cstddef>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "shearzone/core/metadata.hpp"
#include "shearzone/core/unset.hpp"
#include "shearzone/core/waveform.hpp"

namespace shearzone::io {

enum class LogFormat { kAuto, kCsv, kAntonPaar, kTrios, kRepTate, kMalvern };
/// "auto", "csv", "anton-paar", "trios", "reptate", "malvern".
const char* log_format_name(LogFormat f);
LogFormat log_format_from_name(const std::string& name);

enum class LogQuantity { kAngleTorque, kStrainStress };

struct LogReadOptions {
  LogFormat format = LogFormat::kAuto;  ///< auto: by content (BOM/UTF-16, "Interval data:", "[", header)
  LogQuantity quantity = LogQuantity::kAngleTorque;
  /// Column names for generic CSV/TSV (exact header text, before any unit suffix
  /// handling). Empty time column name: the log has no time. The defaults are the
  /// toolkit's own names; their units come from the suffix (_s, _rad, _N_m).
  std::string time_column = "time_s";
  std::string angle_column = "angle_rad";    ///< or strain column in strain/stress mode
  std::string torque_column = "torque_N_m";  ///< or stress column in strain/stress mode
  std::string interval_column;               ///< optional: a new segment when it changes
  /// Unit overrides for generic tables (empty: from the column name's suffix or the
  /// units row). Accepted: time s, ms; angle rad, mrad, deg; torque N m, mN m, uN m
  /// (also written N·m, Nm, µN·m, mNm ...); strain 1 (dimensionless), %; stress Pa.
  std::string time_unit, angle_unit, torque_unit;
  /// Inspection (`laos --inspect`): a file without any analysable segment is returned
  /// with its skipped blocks instead of being refused.
  bool inspect = false;
};

/// One segment of a log: its samples (drive: angle in rad or strain; response:
/// torque in N m or stress in Pa; time empty when the log has none; line: 1-based
/// source line of each sample) and the interval or step name.
struct LogSegment : core::Waveform {
  std::string label;               ///< interval / step name, or "1", "2", ...
  /// The samples are exactly one closed drive period, the last sample equal to the
  /// first (an Anton Paar measuring point with a stored waveform): analysed as one
  /// exact period (laos::analyse_closed_cycle), not cut into cycles.
  bool closed_cycle = false;
  /// What the instrument itself reported for this segment (kUnset when absent): its
  /// frequency, its storage and loss moduli G', G'' and its torque amplitude.
  double instrument_frequency_Hz = core::kUnset;
  double instrument_G_prime_Pa = core::kUnset, instrument_G_dprime_Pa = core::kUnset;
  double instrument_torque_N_m = core::kUnset;
};

struct OscillationLog {
  std::string source;              ///< file name, for messages
  LogFormat format = LogFormat::kCsv;
  /// The options' quantity, except for RepTate files, whose units decide it (angle
  /// and torque when the drive is in rad, as in SlugSlime; else strain and stress).
  LogQuantity quantity = LogQuantity::kAngleTorque;
  std::vector<LogSegment> segments;
  /// Blocks of the file that hold no raw waveform (summary tables, rests), each as
  /// "<label> (line L): <why>": skipped, not fatal, and listed by `laos --inspect`.
  std::vector<std::string> skipped;
  /// Parameters found in the file: TRIOS `[Section]` entries (e.g. "Stress constant"
  /// in Pa/(N m) as "stress_constant_Pa_per_N_m", "Strain constant" in 1/rad as
  /// "strain_constant_per_rad"), a RepTate header's omega and gamma
  /// ("omega_rad_per_s", "gamma0"), the export's own header lines.
  core::Metadata parameters;
  /// Convenience lookups of `parameters` (NaN when absent).
  double omega_rad_per_s = core::kUnset;
  double stress_constant_Pa_per_N_m = core::kUnset;
  double strain_constant_per_rad = core::kUnset;
};

/// Reads a log. Throws InputError (file, line, bad value, what was expected) or
/// ConfigError (options that do not fit the file).
OscillationLog read_oscillation_log(const std::filesystem::path& path,
                                    const LogReadOptions& options = {});

/// Text decoding shared by the readers: UTF-8 (with or without BOM) or UTF-16 LE/BE
/// with a BOM, to UTF-8. Throws InputError for invalid UTF-16. Also accepted: UTF-16
/// LE without a BOM (recognised by zero high bytes in the first two code units), and
/// bytes that are not valid UTF-8, read as Latin-1.
///
/// Format auto-detection (read_oscillation_log, format kAuto), in this order: a line
/// whose first cell is "Interval data:" / "Intervalldaten:" / "Données d'intervalle:",
/// or any TAB line whose first cell ends with ':' and names three or more columns
/// (a RheoCompass table in any language) -> Anton Paar; a "[...]" section line and
/// name/value lines (TAB, or two ',' cells: the CSV export) -> TRIOS; any other
/// UTF-16 file (BOM) -> Anton Paar; a first line of ';' cells starting with "Action Name"
/// -> Malvern rSpace; extension .laos or a first line "key=value;" ->
/// RepTate; else generic CSV/TSV. Units: shearzone/io/units.hpp.
std::string decode_text(const std::string& bytes, const std::string& source);

}  // namespace shearzone::io
