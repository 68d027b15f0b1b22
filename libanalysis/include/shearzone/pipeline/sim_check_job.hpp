// shearzone/pipeline/sim_check_job.hpp: `shearzone sim check`: the closed loop. A
// simulated run is filmed (sim_render_job.hpp), the video goes through the lab
// pipeline (piv -> profile -> width) with the geometry from the camera, and the
// result is set against the simulator's truth, per amplitude branch and PIV setting.
//
// Three widths per branch:
//   video     r_c of the lab pipeline on the rendered video;
//   centres   r_c of the camera's truth: the surface beads' centre motion on the same
//             camera (visible_motion; what PIV of shiny spheres can at best recover);
//   surface   r_c of the simulator's surface field (surface.h5: the beads' material
//             points, spin included).
// The PIV error is per vector against the camera's truth at the same node and pair.
//
// OUT/closed_loop.csv has one row per branch and PIV setting; OUT/<branch>/ holds the
// video and its camera files, the truths' fields, profiles and widths, and per
// setting OUT/<branch>/<setting>/ the PIV fields, profile and width.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "shearzone/core/metadata.hpp"
#include "shearzone/core/progress.hpp"
#include "shearzone/pipeline/piv_job.hpp"
#include "shearzone/pipeline/sim_render_job.hpp"
#include "shearzone/pipeline/width_job.hpp"
#include <functional>
#include "shearzone/profile/width.hpp"

namespace shearzone::pipeline {

/// One setting of the grid: the window sizes per pass, the pair spacing k (pairs
/// (i, i + k) of the video's frames) and the image deformation's interpolation (empty:
/// the PIV options'), or bead tracking at spacing k.
struct SimCheckSetting {
  std::vector<int> windows_px;
  int spacing = 1;
  std::string interpolation;
  /// PIV (the windows above) or bead tracking (`piv --method track`: no windows).
  PairMethod method = PairMethod::kPiv;
  [[nodiscard]] std::string label() const;  ///< "w64-32-16_k1", "w64-32-16_bilinear_k1", "track_k1"
};

struct SimCheckOptions {
  std::filesystem::path run_dir;     ///< a run with frames.h5, or a protocol run (its branch folders)
  std::filesystem::path output_dir;
  bool force = false;
  SimRenderOptions render;           ///< camera and look (run, output and force are set per branch)
  PivJobOptions piv;                 ///< PIV options (inputs, output, geometry and spacing set here)
  std::vector<SimCheckSetting> settings;  ///< empty: piv's windows at spacing 1
  profile::WidthOptions width;       ///< v_c and the bootstrap of every width
  double truth_spacing_px = 8.0;     ///< grid step of the camera's truth field
  void validate() const;
};

struct SimCheckRow {
  std::string branch, setting;
  double phi0_rad = 0, bead_diameter_m = 0;
  double bead_diameter_px = 0;  ///< on the video, at the bead surface
  int N = 1;
  std::size_t pairs = 0;
  WidthRow video, centres, surface;
  double profile_rms_diff_m_per_s = 0;          ///< video against centres, over the bins both hold
  double profile_rms_diff_surface_m_per_s = 0;  ///< video against surface
  double piv_rms_error_px = 0, piv_bias_u_px = 0, piv_bias_v_px = 0;
  std::size_t compared_vectors = 0;
  double invalid_fraction = 0;  ///< invalid / not masked
  double render_s = 0, piv_s = 0, profile_s = 0, width_s = 0, truth_s = 0;
};

/// Called as each stage starts: its name ("phi0_0.300: piv w64-32-16_k1"), the stages
/// done and their total.
using SimCheckProgress = std::function<void(const std::string& stage, std::size_t done, std::size_t total)>;

std::vector<SimCheckRow> run_sim_check(const SimCheckOptions& options, const core::Metadata& header,
                                       const SimCheckProgress& stage = {});

}  // namespace shearzone::pipeline
