// shearzone/pipeline/width_job.hpp: `shearzone width`.
//
// Profile CSVs (io/profile_csv.hpp, with their `<stem>_groups.csv`) -> one row per
// profile: label, tags, r_c, its bootstrap interval, status, noise floor and pair count
// (profile/width.hpp computes r_c).
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "shearzone/core/metadata.hpp"
#include "shearzone/profile/width.hpp"

namespace shearzone::pipeline {

struct WidthJobOptions {
  std::vector<std::filesystem::path> inputs;  ///< profile CSVs
  std::filesystem::path output;               ///< widths CSV
  bool force = false;
  std::vector<std::pair<std::string, std::string>> tags;  ///< KEY=VALUE for every row (N, phi0_rad)
  profile::WidthOptions width;                ///< threshold, noise factor, bootstrap
  /// ConfigError for no input, a width option out of range or a tag other than N and
  /// phi0_rad; run before any file is read.
  void validate() const;
};

struct WidthRow {
  std::string label, advice;
  profile::WidthStatus status = profile::WidthStatus::kOk;
  profile::Estimator estimator = profile::Estimator::kMeanAbs;  ///< the one used
  double rc_m = 0;  ///< NaN when not reported (noise_limited)
  double ci_low_m = 0, ci_high_m = 0;  ///< the bootstrap interval (NaN: none)
  double v_noise_m_per_s = 0;          ///< the floor the status used
};

/// Returns one row per input (status and, for noise_limited, the advice text).
/// The CLI exits 3 when no row has status ok (the file is still written).
std::vector<WidthRow> run_width_job(const WidthJobOptions& options, const core::Metadata& header);

}  // namespace shearzone::pipeline
