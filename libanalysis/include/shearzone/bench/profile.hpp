// shearzone/bench/profile.hpp: `shearzone bench profile`, the profile and width
// stages on a long clip, against truth.
//
// Writes a synthetic field file (synth/zone_fields.hpp; by default the 4-minute 1080p
// clip: 6000 pairs on the 8 px grid, 1e-4 m/px, 25 fps, an exponential shear zone
// oscillating at 0.1 Hz, 0.02 px of noise per component, true r_c = 20.97 mm at
// v_c = 4e-5 m/s), runs `profile` on it (streamed) and `width` with the mean |v| and
// the lock-in estimators, and tabulates time, peak memory and r_c against the truth
// (profile_bench.csv). The field file is deleted afterwards unless kept.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "shearzone/core/metadata.hpp"
#include "shearzone/core/progress.hpp"

namespace shearzone::bench {

struct BenchProfileOptions {
  int pairs = 6000;             ///< 4 minutes at 25 fps
  double spacing_px = 8.0;      ///< PIV grid step
  int width_px = 1920, height_px = 1080;
  double f_Hz = 0.1;
  double noise_px = 0.02;
  int lockin_harmonics = 7;
  std::filesystem::path out_dir;
  bool force = false;
  bool keep_fields = false;     ///< keep zone_fields.h5 (about 10 bytes per vector)
  void validate() const;
};

struct BenchProfileSummary {
  std::vector<std::filesystem::path> files;
  std::vector<std::string> lines;  ///< one per estimator, for the terminal
};

BenchProfileSummary run_profile_bench(const BenchProfileOptions& options, const core::Metadata& header,
                                      const core::ProgressCallback& progress = {});

}  // namespace shearzone::bench
