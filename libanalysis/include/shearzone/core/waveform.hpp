// shearzone/core/waveform.hpp: one sampled drive/response record, the type the
// oscillation-log readers (io) produce and the LAOS analysis (laos) consumes.
#pragma once

#include <cstddef>
#include <vector>

namespace shearzone::core {

/// Samples k = 0..n-1 of a drive x (rad, or strain) and its response r (N m, or Pa).
/// `drive` and `response` have n entries; `time_s` has n or none (the record has no
/// time); `line` has n (1-based source line of each sample, for messages) or none.
struct Waveform {
  std::vector<double> time_s;
  std::vector<double> drive;
  std::vector<double> response;
  std::vector<std::size_t> line;
};

}  // namespace shearzone::core
