// shearzone/track/track.hpp: bead tracking between two frames, a second estimator of
// the displacement field beside PIV (docs/track.md).
//
// Each bead is measured on its own: its centre is found in frame a (a local maximum
// of the frame smoothed at the bead's scale), and its displacement to frame b by
// pyramidal Lucas-Kanade on a window of 3/4 of a bead around it (OpenCV's
// calcOpticalFlowPyrLK), checked by tracking back from b to a (forward-backward). No
// window averages the motion of several beads, so beads that rattle independently keep
// their own |v| (PIV's windows read the mean of such vectors short: docs/sim.md).
//
// beads_to_grid() then puts the beads on a grid of cells half a bead wide, each
// valid cell the mean displacement of the beads whose centre lies in it (almost always
// one), so that the field files, `profile` and `width` take tracked fields as they take
// PIV fields.
//
// Conventions: pixel (row i, column j) has its centre at (x, y) = (j, i); displacements
// in px from frame a to frame b, y down; masks are 8-bit, non-zero = masked.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "shearzone/core/metadata.hpp"
#include "shearzone/core/tracked_beads.hpp"
#include "shearzone/core/vector_field.hpp"

namespace shearzone::track {

struct TrackOptions {
  /// Bead diameter in the image, px (3..200). The window of each bead is three quarters
  /// of it (odd, at least 7 px) and the detection's smoothing a sixth of it.
  double bead_diameter_px = 0.0;
  /// A bead is kept when tracking it back from b lands within this of where it started, px.
  double fb_tolerance_px = 0.1;
  /// Pyramid levels above the full image (0..6): displacements up to about half a
  /// window times 2^levels are found.
  int pyramid_levels = 3;
  /// Lucas-Kanade iterations per level and the step below which they stop, px.
  int max_iterations = 100;
  double epsilon_px = 1e-4;
  /// A detection needs a local contrast (peak of the smoothed frame over the lowest
  /// value within a square of side 0.7 bead diameters) of at least this fraction of the frame's
  /// range (1st to 99th percentile of the smoothed frame, unmasked pixels).
  double min_contrast = 0.05;
  /// From the peak of a bead's smoothed image to the centre of its disc, px: under a
  /// light from one side the peak lies towards the light (a sixth of a bead and more on
  /// the `synth beads` look). Added to every peak found; disc_centre_offset() measures it.
  cv::Point2d centre_offset_px{0.0, 0.0};
  void validate() const;
  core::Metadata to_metadata() const;
};

/// Bead centres found in a frame, px (sub-pixel: a parabola through the smoothed
/// frame's peak and its neighbours). A bead is dropped when a masked pixel or the
/// image's edge lies within a quarter diameter (at least 3.5 px) of its centre, or when
/// its centre lies in `outside`.
///
/// Two masks, because they mean different things to a bead: `mask` covers what hides
/// beads (a vane blade, a shaft, a label: a window must stay clear of it), `outside`
/// only where no bead is counted (the annulus of interest's complement). A bead whose
/// centre lies just inside the annulus's inner edge, at the vane's radius, is all in
/// view: the beads between the blades lie beyond that edge. Kept clear of it like a
/// blade, the beads of the first quarter bead were lost, and they are the fastest (the
/// closed loop's first bin read 0.45 mm/s for the camera's 0.59: docs/track.md).
std::vector<cv::Point2d> detect_beads(const cv::Mat& image, const cv::Mat& mask, const TrackOptions& options,
                                      const cv::Mat& outside = cv::Mat());

/// The offset from the peak of a bead's smoothed image to the centre of its disc (for
/// TrackOptions::centre_offset_px), measured on a frame: the mean image of its beads
/// about their peaks (out to 0.9 d, beads that far from the edge; masked pixels left
/// out), and in it the circle of the bead's diameter that best separates the bead from
/// what lies around it (the largest mean difference between points d/16 inside and
/// outside it), for offsets up to 0.35 d. A frame with fewer than kMinOffsetBeads such
/// beads, or whose beads' surroundings are mostly masked, gives (0, 0).
cv::Point2d disc_centre_offset(const cv::Mat& image, const cv::Mat& mask, const TrackOptions& options);
inline constexpr int kMinOffsetBeads = 30;

/// The beads of frame a and their displacements to frame b.
struct PairBeads {
  std::vector<double> x_px, y_px;  ///< centres in frame a
  std::vector<double> u_px, v_px;  ///< displacement a -> b (0 where !ok)
  std::vector<double> fb_px;       ///< forward-backward distance (NaN where the tracker lost the bead)
  std::vector<std::uint8_t> ok;    ///< 1: tracked, back within the tolerance, clear of mask b
  std::size_t size() const { return x_px.size(); }
  std::size_t tracked() const;
};

/// Tracks the beads of `a` into `b` (8-bit or 16-bit grey, the same size; 16-bit frames
/// are scaled to 8 bits first). Each bead's window is 3/4 of a bead, or smaller where a
/// masked pixel or the edge is nearer (it stays clear of them: a wall or a vane in the
/// window would pull the bead towards their motion), at least 7 px. A bead whose window
/// at its end reaches a masked pixel of `mask_b` (the vane moved over it) is not ok.
/// Beads whose centre lies in `outside` (static: where no bead counts) are not
/// tracked; windows may reach into it (detect_beads).
PairBeads track_pair(const cv::Mat& a, const cv::Mat& b, const cv::Mat& mask_a, const cv::Mat& mask_b,
                     const TrackOptions& options, const cv::Mat& outside = cv::Mat());

/// Cell size of the grid of beads_to_grid for a bead diameter: half a bead, at least 2 px.
int grid_cell_px(double bead_diameter_px);

/// The beads on a grid of `cell_px` cells over an image of `size`: node (i, j) at the
/// centre of the cell of pixels [j c, (j + 1) c) x [i c, (i + 1) c). A cell whose centre
/// is masked in `mask_a`, or that holds no bead centre, is kMasked; one whose beads all
/// failed is kInvalid; else kValid with the mean displacement of its ok beads. peak and
/// peak_ratio (correlation measures) are 0.
core::VectorField beads_to_grid(const PairBeads& beads, cv::Size size, int cell_px, const cv::Mat& mask_a);

/// Links the beads of consecutive pairs into tracks. A bead of a pair's frame a
/// continues a track of the previous pair when that pair's frame b is this frame a and
/// the bead's centre is the mutual nearest, within a quarter bead, of where a tracked
/// bead of that pair ended (its centre plus its displacement): both are the same
/// bead's detection and Lucas-Kanade's estimate of it, while the nearest other bead is
/// at least half a bead away (detect_beads keeps one per half bead). Any other bead
/// starts a new track (it appeared, came out from under the vane, or its previous
/// displacement failed its checks); a track ends where its bead is not tracked.
class Linker {
 public:
  explicit Linker(double bead_diameter_px);
  /// The rows of one pair (frames frame_a -> frame_b, t_a_s, dt_s), with track ids.
  /// Pairs come in time order; ids count from 0 in order of appearance.
  core::TrackedBeads link(const PairBeads& beads, std::int64_t frame_a, std::int64_t frame_b, double t_a_s,
                          double dt_s);
  /// Tracks started so far.
  std::int64_t tracks() const { return next_id_; }
  /// Beads of the pairs that continued the previous pair (frame a its frame b), and
  /// how many of those continued a track: the fraction linked.
  std::size_t linkable() const { return linkable_; }
  std::size_t linked() const { return linked_; }

 private:
  double gate_px_;
  std::int64_t prev_frame_b_ = -1;
  std::vector<double> end_x_, end_y_;    // where the previous pair's tracked beads ended
  std::vector<std::int64_t> end_ids_;    // their tracks
  std::int64_t next_id_ = 0;
  std::size_t linkable_ = 0, linked_ = 0;
};

}  // namespace shearzone::track
