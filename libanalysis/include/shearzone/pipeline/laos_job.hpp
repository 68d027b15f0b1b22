// shearzone/pipeline/laos_job.hpp: `shearzone laos`: oscillation logs (torque and
// angle, or stress and strain) -> harmonics, tan δ, Chebyshev measures per amplitude.
//
// Reads each log through io::read_oscillation_log, runs laos::analyse_record on each
// segment (interval / step block), and writes into the output folder (all files or
// none, io::AtomicOutputSet): summary.csv (one row per amplitude of every log),
// cycles.csv, harmonics.csv and lissajous_NN.csv (NN = the amplitude's row in the
// summary). Columns: docs/formats.md.
#pragma once

#include <cstddef>
#include <filesystem>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "shearzone/core/metadata.hpp"
#include "shearzone/core/unset.hpp"
#include "shearzone/io/oscillation_log.hpp"
#include "shearzone/laos/analysis.hpp"
#include "shearzone/laos/spp.hpp"

namespace shearzone::pipeline {

struct LaosJobOptions {
  std::vector<std::filesystem::path> inputs;  ///< logs
  std::filesystem::path output;               ///< output folder
  bool force = false;
  /// KEY=VALUE for every summary row; N (chain length) is always a column, from here
  /// or from the log's parameters ("N"), empty when unknown.
  std::vector<std::pair<std::string, std::string>> tags;
  io::LogReadOptions read;
  laos::AnalysisOptions analysis;  ///< omega_rad_per_s and inertia are set from below
  double f_Hz = core::kUnset;  ///< drive frequency (else the log's)
  double inertia_kg_m2 = 0.0;      ///< instrument inertia: τ − I φ̈ (angle/torque logs)
  /// Vane constants: stress = C_s τ (Pa per N m), strain = C_γ φ (per rad). Both, or
  /// `log_constants` to take them from the log (TRIOS "Stress/Strain constant").
  double stress_constant_Pa_per_N_m = core::kUnset;
  double strain_constant_per_rad = core::kUnset;
  bool log_constants = false;
  /// --spp: the transient moduli within the cycle (laos/spp.hpp): spp_summary.csv and
  /// spp_NN.csv beside the other tables.
  bool spp = false;
  laos::SppOptions spp_options;
  void validate() const;
};

struct LaosSummaryRow {
  std::string source, segment;
  laos::AmplitudeStatus status = laos::AmplitudeStatus::kOk;
  std::size_t amplitude = 0;  ///< 1-based row index
  double x0 = 0, r_max = 0, K1p = 0, K1pp = 0, tan_delta = 0, I3_over_I1 = 0, phi_d = 0;
  int M = 0, cycles_used = 0, cycles_complete = 0;
};

struct LaosJobSummary {
  bool stress_strain = false;  ///< outputs in Pa / strain units
  std::vector<LaosSummaryRow> rows;
  std::size_t logs = 0, skipped_blocks = 0;
  std::size_t spp_refused = 0;  ///< amplitudes too coarse for SPP (with --spp)
  struct SppRow {
    int M = 0;                   ///< 0: refused (too coarse)
    laos::SppMeasure cage, static_yield, dynamic_yield;
  };
  std::vector<SppRow> spp_rows;  ///< with --spp: one per row of `rows`
  std::vector<std::filesystem::path> files;
};

LaosJobSummary run_laos_job(const LaosJobOptions& options, const core::Metadata& header);

/// `laos --inspect`: for each input, the detected format and quantity, the analysable
/// segments (label, source lines, samples, time or closed cycle, the instrument's own
/// values) and the skipped blocks with the reason (their columns), as plain text. Reads
/// with options.read (inspect on); writes nothing. InputError for a file that cannot be
/// read at all.
std::string inspect_laos_logs(const LaosJobOptions& options);

}  // namespace shearzone::pipeline
