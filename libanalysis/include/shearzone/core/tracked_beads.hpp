// shearzone/core/tracked_beads.hpp: beads measured pair by pair and linked into
// tracks, as rows (one per bead detected in a pair's frame a). The tracker fills them
// (track/track.hpp, track::Linker); io/track_file.hpp writes and reads them.
//
// Conventions: pixel (row i, column j) has its centre at (x, y) = (j, i); positions
// in px in frame a; displacements in px from frame a to frame b, y down; times in s.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace shearzone::core {

struct TrackedBeads {
  std::vector<std::int64_t> track_id;        ///< the bead's track: the same id from pair to pair
  std::vector<std::int64_t> frame_a, frame_b;  ///< the pair's frame indices
  std::vector<double> t_a_s, dt_s;           ///< time of frame a and of the pair
  std::vector<double> x_px, y_px;            ///< the bead's centre in frame a
  std::vector<double> u_px, v_px;            ///< its displacement a -> b (NaN where not tracked)
  std::vector<double> fb_px;                 ///< forward-backward distance (NaN where LK lost it)
  std::vector<std::uint8_t> tracked;         ///< 1: displacement measured and checked
  std::vector<std::uint8_t> linked;          ///< 1: continues a track of the previous pair

  std::size_t size() const { return track_id.size(); }
};

}  // namespace shearzone::core
