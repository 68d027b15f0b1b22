// shearzone/pipeline/collapse_fss_job.hpp: `shearzone collapse fss` from files to files.
//
// Input: one long CSV table, one row per point, with the columns named by the options
// (control parameter x, observable y, optional error dy, system size L). Rows may come
// in any order; they are grouped by exact L value and sorted by x.
// Without a dy column every point gets dy = 1 and the errors are rescaled after the
// minimisation so that S_min = 1 (errors estimated from the collapse scatter, like
// scaling by sqrt(chi^2_red)); the S+1 errors are then relative to that estimate.
//
// Outputs (in out_dir, all or nothing):
//   collapse_fss_params.csv  parameter,value,err_low,err_high,boot_ci_low,boot_ci_high,fixed
//                            rows x_c, a, b, then S_min and n_terms (value only).
//   collapse_fss_points.csv  L,x,y,dy,x_scaled,y_scaled,dy_scaled,in_window per input point
//                            (sorted by L, then x).
//   collapse_fss_master.csv  all points sorted by x_scaled with the master curve at each:
//                            x_scaled,y_scaled,dy_scaled,L,Y,dY,in_window,term.
// Units: L, x, y, dy as in the input columns (named in the header block);
// x_scaled = (x - x_c) L^a in units of x times L^a, y_scaled, dy_scaled, Y, dY in units
// of y times L^b; S and term are dimensionless. Empty cells: not defined.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "shearzone/core/metadata.hpp"
#include "shearzone/fit/collapse_fss.hpp"

namespace shearzone::pipeline {

struct CollapseFssJobOptions {
  std::filesystem::path input;
  std::string x_column, y_column, dy_column, L_column;  ///< dy_column empty: no errors
  std::vector<double> sizes;  ///< use only rows with these L (empty: all)
  fit::FssFitOptions fit;
  std::filesystem::path out_dir;
  bool force = false;

  /// ConfigError on missing column names or bad fit options.
  void validate() const;
};

struct CollapseFssJobSummary {
  fit::FssFitResult result;
  std::size_t rows = 0;               ///< points used
  std::vector<double> sizes;          ///< distinct L, ascending
  bool unit_errors = false;           ///< no dy column: dy = 1, rescaled
  std::vector<std::filesystem::path> outputs;
};

/// Names of the three output files, in the order they are written.
std::vector<std::string> collapse_fss_output_names();

CollapseFssJobSummary run_collapse_fss_job(const CollapseFssJobOptions& options,
                                           const core::Metadata& header);

}  // namespace shearzone::pipeline
