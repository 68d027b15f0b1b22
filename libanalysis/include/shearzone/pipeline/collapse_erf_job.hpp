// shearzone/pipeline/collapse_erf_job.hpp: `shearzone collapse erf` from a CSV table
// to an output folder (fit/erf_collapse.hpp does the work).
//
// Outputs in DIR (all or none):
//   collapsed.csv   group,N,x,y,phi_tilde,r_tilde,r_tilde_sigma,phi_tilde_global,
//                   r_tilde_global,status (own fit: phi~ = (x − phi_c)/W,
//                   r~ = (y − rc0)/(rcinf − rc0); _global: with the global fit);
//                   rows only for groups with a fit;
//   master.csv      phi_tilde,r_tilde: ½(1 + erf(phi~)) on a grid over [−3, 3];
//   parameters.csv  scope,parameter,value,std_error,ci_low,ci_high,unit,status:
//                   scope "global" (phi_c, W0, alpha, rc0_<g>, rcinf_<g>) and one
//                   scope per group (its own rc0, rcinf, phi_c, W); the global fit's
//                   statistics and N_ref are in the header.
#pragma once

#include <filesystem>
#include <string>

#include "shearzone/core/metadata.hpp"
#include "shearzone/fit/erf_collapse.hpp"

namespace shearzone::pipeline {

struct CollapseErfJobOptions {
  std::filesystem::path input;
  std::filesystem::path out_dir;
  std::string x_column, y_column, sigma_column, group_column;
  double group_rtol = 0.02;
  fit::FitOptions fit;
  int grid_points = 241;  ///< master-curve grid
  bool force = false;
  void validate() const;
};

struct CollapseErfJobSummary {
  fit::ErfCollapseResult result;
  std::vector<std::string> labels;
  std::string report;
};

CollapseErfJobSummary run_collapse_erf_job(const CollapseErfJobOptions& options,
                                           const core::Metadata& header);

}  // namespace shearzone::pipeline
