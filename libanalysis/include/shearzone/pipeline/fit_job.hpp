// shearzone/pipeline/fit_job.hpp: curve fits from a CSV table (`shearzone fit`).
//
// Reads TABLE, splits it into groups (--group COL; numeric group values equal
// within a relative tolerance are one group), fits each group (erf transition or
// power law, fit/models.hpp) and writes three CSV files:
//   OUT            long:  group,parameter,value,std_error,ci_low,ci_high,unit
//                         (+ boot_low,boot_high with --bootstrap); one row per
//                         parameter of each group that has a solver result;
//   OUT_wide       one row per group: group,rc0,rc0_se,...,status (power:
//                         group,A,A_se,k,k_se,status); empty cells where there is
//                         no number; units in `# unit_<column>:` header lines;
//   OUT_summary    per group: status, message, n, p, dof, chi2, reduced_chi2, aic,
//                         aicc, bic, cond, iterations, termination, correlations.
// Rows of TABLE whose `status` column (if there is one) is not "ok" are skipped,
// so that a wide file chains into the next fit.
#pragma once

#include <cstddef>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "shearzone/core/metadata.hpp"
#include "shearzone/core/unset.hpp"
#include "shearzone/fit/least_squares.hpp"
#include "shearzone/fit/models.hpp"

namespace shearzone::pipeline {

enum class FitModel { kErf, kPower };

struct FitJobOptions {
  FitModel model = FitModel::kErf;
  std::filesystem::path input;
  std::filesystem::path output;      ///< the long CSV; _wide and _summary beside it
  std::string x_column, y_column;
  std::string sigma_column;          ///< empty: unit weights
  std::string group_column;          ///< empty: one group
  double group_rtol = 0.02;          ///< numeric group values within this are one group
  fit::FitOptions fit;
  fit::PowerSpace space = fit::PowerSpace::kLinear;  ///< power only
  double subtract_at = core::kUnset;  ///< power only; NaN: off
  double subtract_rtol = 1e-9;       ///< x within this of subtract_at is the reference
  bool force = false;

  void validate() const;  ///< ConfigError on bad options
};

struct FitGroupResult {
  std::string group;
  fit::CurveFit fit;
  fit::CurveFit alternative;   ///< power: the other space's fit (report only)
  bool has_alternative = false;
  double y0 = core::kUnset;  ///< subtracted y(x0)
};

struct FitJobSummary {
  std::vector<FitGroupResult> groups;
  std::size_t usable = 0;
  std::filesystem::path long_csv, wide_csv, summary_csv;
  std::string report;          ///< readable report of every group
};

/// The wide and summary paths that go with `output` (stem + "_wide" / "_summary").
std::filesystem::path sibling_output(const std::filesystem::path& output, const std::string& suffix);

/// Runs the job. Input problems are InputError naming file:line; outputs are
/// written atomically (all three or none). Does not throw when no group is usable
/// (the caller decides: `usable == 0` is exit 3 in the CLI).
FitJobSummary run_fit_job(const FitJobOptions& options, const core::Metadata& header);

}  // namespace shearzone::pipeline
