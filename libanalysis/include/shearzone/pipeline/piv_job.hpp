// shearzone/pipeline/piv_job.hpp: PIV from files to files (`shearzone piv`).
//
// Inputs: two images (one pair), an image sequence (a glob or a list) or a video.
// Frames are streamed; repeated (duplicate) frames, which some encoders emit, are
// skipped and counted. Pairs are (u_i, u_{i+k}) over the unique frames u, with
// k = pair_spacing, i = 0, stride, 2 stride, ... Time comes from the container's
// timestamps (or index / fps for images), and dt = t_b - t_a.
//
// Outputs (layouts in io/field_file.hpp, the one place that writes and reads them):
//   .csv  one pair, with every option and convention in the `#` header;
//   .h5   any number of pairs, streamed pair by pair, in the layout the next stages read.
// Displacements are in px per pair, from frame a to frame b.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "shearzone/core/metadata.hpp"
#include "shearzone/core/progress.hpp"
#include "shearzone/core/unset.hpp"
#include "shearzone/core/vane.hpp"
#include "shearzone/core/vector_field.hpp"
#include "shearzone/io/frames.hpp"
#include "shearzone/io/image.hpp"
#include "shearzone/piv/options.hpp"
#include "shearzone/piv/preprocess.hpp"
#include "shearzone/track/track.hpp"

namespace shearzone::pipeline {

/// The rotating-vane mask: the blade template of `geometry` at angle
/// angle0 + phi(t) about the centre, counter-clockwise positive as the camera sees
/// it, where phi(t) = phi0 sin(2 pi f t + phase), or phi(t) is read from a log
/// (CSV with columns time_s, angle_rad; linear interpolation) at t + log_offset_s.
struct VaneMaskOptions {
  core::VaneGeometry geometry{0, 0.0, 0.0};  ///< blades = 0: no vane mask
  double angle0_deg = 0.0;   ///< blade 0 direction at phi = 0, deg CCW from +x
  double margin_px = 1.0;    ///< grow the blades by this much (edges, blur)
  double phi0_rad = 0.0;     ///< amplitude of phi(t), rad
  double f_Hz = 0.0;         ///< frequency of phi(t), Hz
  double phase_rad = 0.0;    ///< phase of phi(t), rad
  std::string log_path;      ///< angle log CSV (time_s, angle_rad); empty: sinusoid
  double log_offset_s = 0.0; ///< log time = frame time + offset
  /// Find the offset instead: the vane angle is measured in every selected frame
  /// (piv/vane_angle.hpp) and the offset that best matches the log is used.
  bool log_offset_auto = false;
  /// Find the phase of the sinusoid instead: the vane angle is measured in every
  /// selected frame and phi0 sin(2 pi f t + phase) + c fitted to it by least squares
  /// (f given). The phase used is written to the fields as vane_phase_rad, the drive
  /// phase `profile` locks to.
  bool phase_auto = false;
};

/// How each pair's displacements are measured: PIV (windows correlated) or bead
/// tracking (track/track.hpp: each bead on its own, put on a grid of half-bead cells).
enum class PairMethod { kPiv, kTrack };
const char* pair_method_name(PairMethod m);  ///< "piv", "track"
PairMethod pair_method_from_name(const std::string& name);

struct PivJobOptions {
  PairMethod method = PairMethod::kPiv;
  /// Tracking's options (method kTrack); bead_diameter_px 0: the texture's size in the
  /// first frame (piv/texture.hpp), as for the windows.
  track::TrackOptions track;
  /// Tracking: measure track.centre_offset_px on the first frame (track::disc_centre_offset);
  /// false: as given.
  bool measure_centre_offset = true;
  piv::PivOptions piv;
  piv::PreprocessOptions preprocess;
  std::vector<std::string> inputs;  ///< images, a glob, or one video
  std::filesystem::path output;     ///< .csv (one pair) or .h5
  /// Frames from the caller instead of `inputs` (the Python module's arrays): each call
  /// opens a fresh pass over the same frames (the job reads its source up to four
  /// times: vane phase, background, texture, pairs). Empty: `inputs`.
  std::function<std::unique_ptr<io::FrameSource>()> frames;
  /// Each pair's field to the caller instead of `output` (no file is written): the field,
  /// its frames (a, b) and the header `output` would carry. Empty: `output`.
  std::function<void(const core::VectorField& field, const io::Frame& a, const io::Frame& b,
                     const core::Metadata& header)>
      on_pair;
  /// Tracking only: the beads of every pair, linked into tracks (track::Linker), to
  /// .h5 or .csv (io/track_file.hpp); empty: none.
  std::filesystem::path tracks_output;
  bool force = false;
  double fps = 25.0;                ///< time base of image sequences, Hz
  /// > 0: a video's frames are timed index / video_fps, its time stamps unused (the
  /// CLI's --fps given with a video; for a container whose stamps stall or wrap).
  double video_fps = 0.0;
  io::GreyMode grey = io::GreyMode::kLuma;  ///< colour-to-grey conversion
  std::int64_t first_frame = 0;     ///< first source frame used
  std::int64_t last_frame = -1;     ///< last source frame used (-1: to the end)
  int pair_spacing = 1;             ///< k: pairs (i, i + k) of unique frames
  int stride = 1;                   ///< step between pair starts
  double duplicate_tolerance = 0.0; ///< frames whose max |difference| <= this (grey levels) repeat
  /// Cup centre in px (NaN: unset). Needed by the annulus and vane masks.
  double centre_x_px = core::kUnset;
  double centre_y_px = core::kUnset;
  double annulus_inner_px = 0.0;    ///< static mask: r < inner is masked
  double annulus_outer_px = 0.0;    ///< static mask: r > outer is masked (0: no annulus)
  std::string mask_image;           ///< static mask image: non-zero = masked
  VaneMaskOptions vane;
  /// Extra root attributes (m_per_px, f_Hz, phi0_rad, N, free --attr pairs). Values
  /// that parse as numbers are stored as float64, others as strings.
  std::vector<std::pair<std::string, std::string>> attributes;
  /// Threads (0: OpenMP's default, all cores). A stream of pairs runs one pair per
  /// thread while the next frames are decoded; a single pair (or one thread) runs its
  /// windows in parallel instead. The fields are the same for any count.
  int threads = 0;
  /// Scale the windows by a power of two so that the final window spans 2/3 of a bead
  /// (the texture size measured in the first frame; piv/texture.hpp). Off: the windows
  /// as given.
  bool size_windows_to_texture = true;
  /// Choose the predictor's smoothing fit from the same texture: the quadratic fit for
  /// beads, the Gaussian for particles or an unmeasured texture
  /// (piv::predictor_fit_for_texture). Off: piv.predictor_fit as given.
  bool fit_predictor_to_texture = true;

  /// ConfigError on inconsistent options (checked before any work).
  void validate() const;
};

struct PivJobSummary {
  std::size_t frames_read = 0;
  std::size_t duplicates = 0;   ///< repeated frames skipped
  std::vector<std::int64_t> damaged;  ///< frames the decoder reported damaged: skipped
  std::size_t pairs = 0;
  std::size_t vectors_per_pair = 0;
  std::size_t valid = 0, replaced = 0, masked = 0, invalid = 0;  ///< over all pairs
  double log_offset_s = 0.0;    ///< the angle log's offset used (found, with log_offset_auto)
  double texture_half_width_px = std::numeric_limits<double>::quiet_NaN();  ///< measured in the first frame
  std::vector<int> windows_px;  ///< the windows used (PIV)
  double track_bead_diameter_px = 0.0;  ///< the bead diameter tracked (method kTrack)
  int track_cell_px = 0;        ///< the grid's cell (method kTrack)
  std::size_t beads = 0, beads_tracked = 0;  ///< over all pairs (method kTrack)
  /// Beads of the pairs that continue the previous one, and those that continue a track.
  std::size_t beads_linkable = 0, beads_linked = 0;
  std::int64_t tracks = 0;      ///< tracks started
  std::size_t coarse_predictor_pairs = 0;  ///< pairs whose first pass took the coarse field
  std::size_t refused_pairs = 0;           ///< pairs refused by the coarse estimate (all invalid)
  double coarse_max_displacement_px = 0.0; ///< largest coarse displacement over the pairs
  double phase_rad = 0.0;       ///< the vane phase used (found, with phase_auto)
  double phase_rms_rad = 0.0;   ///< rms residual of the phase fit (phase_auto)
  double phase_amplitude_rad = 0.0;  ///< amplitude of the fitted sinusoid (phase_auto)
  double seconds = 0.0;         ///< wall time of the job
  int threads = 1;              ///< threads used
  bool pairs_in_parallel = false;  ///< one pair per thread (else windows in parallel)
};

PivJobSummary run_piv_job(const PivJobOptions& options, const core::Metadata& header,
                          const core::ProgressCallback& progress = {});

}  // namespace shearzone::pipeline
