// shearzone/bench/piv.hpp: the PIV speed-accuracy benchmark.
//
// Two tables, both on synthetic pairs with exact truth (48 px border excluded):
//  1. Speed against accuracy: a grid of settings (pass list, interpolation, sub-pixel
//     method, final-pass repeats) on one 1920x1080 vane-like shear-zone pair
//     (rigid core r0 = 200 px, w = 80 px, U0 = 4 px, 3 px particles, 0.02 ppp).
//     Columns: setting, seconds per pair, pairs per second, RMS error, mean error
//     (bias) along x and y, % invalid.
//  2. Failure map with the default settings (512x512): error against the
//     displacement (uniform, up to the first window), particle density, noise, and
//     bead diameter (bead texture, shear zone U0 = d/2, w = 2d, final window 16 px).
// Timings are wall-clock medians over `repeats` runs with the threads OpenMP gives.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "shearzone/core/metadata.hpp"
#include "shearzone/core/progress.hpp"

namespace shearzone::bench {

struct BenchPivOptions {
  int width_px = 1920;
  int height_px = 1080;
  int timing_repeats = 3;   ///< runs per setting; the median time counts
  bool quick = false;       ///< a smaller grid and 960x540 pairs (a smoke run)
  std::filesystem::path out_dir;
  bool force = false;
};

struct BenchPivSummary {
  std::vector<std::filesystem::path> files;
  std::string best_line;  ///< the default setting's line, for the terminal
};

BenchPivSummary run_piv_bench(const BenchPivOptions& options, const core::Metadata& header,
                              const core::ProgressCallback& progress = {});

}  // namespace shearzone::bench
