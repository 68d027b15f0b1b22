// shearzone/bench/track.hpp: the bead tracker's speed against accuracy.
//
// One table on synthetic pairs with exact truth: for each bead diameter, a
// width x height `synth beads` pair of an oscillating-cup-like shear zone (rigid core a
// fifth of the shorter side, decay 2 d, d/4 px per frame at the core), tracked with the
// defaults (the centre offset measured on frame a first, as piv does for a clip).
// Columns: bead diameter, beads detected, seconds for the detection alone and for the
// whole pair (detection, Lucas-Kanade forward and back), pairs per second, the
// beads tracked, and the displacement error against the tracer under each bead (a
// tracer within d/4, no second one within d/2): bias per component and RMS.
// Timings are wall-clock medians over `repeats` runs with the threads OpenCV gives.
// Then a clip's throughput: `clip_pairs` pairs tracked `threads` at a time, one pair per
// thread, as `piv --method track` runs a clip (frames in memory: decoding not counted),
// pairs per second of wall-clock time (median over `repeats` clips).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "shearzone/core/metadata.hpp"
#include "shearzone/core/progress.hpp"

namespace shearzone::bench {

struct BenchTrackOptions {
  int width_px = 1920;
  int height_px = 1080;
  std::vector<double> diameters_px{16, 24, 35, 50};
  int timing_repeats = 3;  ///< runs per diameter; the median time counts
  int threads = 0;         ///< pairs tracked at a time in the clip's throughput (0: all cores, as piv)
  int clip_pairs = 24;     ///< pairs per timed clip
  bool quick = false;      ///< 960x540 and 35 px beads only (a smoke run)
  std::filesystem::path out_dir;
  bool force = false;
};

struct BenchTrackSummary {
  std::vector<std::filesystem::path> files;
  std::vector<std::string> lines;  ///< one per diameter, for the terminal
};

BenchTrackSummary run_track_bench(const BenchTrackOptions& options, const core::Metadata& header,
                                  const core::ProgressCallback& progress = {});

}  // namespace shearzone::bench
