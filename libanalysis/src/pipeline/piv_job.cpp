#include "shearzone/pipeline/piv_job.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <deque>
#include <functional>
#include <memory>
#include <numbers>
#include <optional>
#include <utility>

#include <omp.h>

#include <fmt/format.h>


#include "shearzone/core/conventions.hpp"
#include "shearzone/core/enum_names.hpp"
#include "shearzone/core/error.hpp"
#include "shearzone/core/ordered_pool.hpp"
#include "shearzone/core/vector_field.hpp"
#include "shearzone/core/version.hpp"
#include "shearzone/io/atomic_output.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/io/field_file.hpp"
#include "shearzone/io/file.hpp"
#include "shearzone/io/frames.hpp"
#include "shearzone/io/image.hpp"
#include "shearzone/io/track_file.hpp"
#include "shearzone/io/video.hpp"
#include "shearzone/piv/mask.hpp"
#include "shearzone/piv/texture.hpp"
#include "shearzone/piv/piv.hpp"
#include "shearzone/piv/vane_angle.hpp"

namespace shearzone::pipeline {
namespace {

using io::format_number;

bool frames_equal(const cv::Mat& a, const cv::Mat& b, double tol) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) <= tol;
}

std::string metadata_text(const core::Metadata& m) {
  std::string s;
  for (const auto& [k, v] : m) s += k + ": " + v + "\n";
  return s;
}

/// A frame PIV may still pair: the frame, what PIV sees (preprocessed if asked), its
/// mask (static + annulus + vane at this frame's time) and, for tracking, what of it
/// hides beads (static + vane: the annulus only bounds where beads count).
struct Unique {
  io::Frame frame;
  cv::Mat image;
  cv::Mat mask;
  cv::Mat hiding;
};

/// One pair's displacements: PIV's result, or the beads tracked and their grid.
struct PairResult {
  piv::PivResult piv;
  track::PairBeads beads;
};
using PairEstimator = std::function<PairResult(const Unique& a, const Unique& b)>;

/// One pair in flight: its frames and, once done, its result.
struct PairJob {
  std::shared_ptr<const Unique> a, b;
  PairResult result;
};
using PairPool = core::OrderedPool<PairJob>;

/// Sets this thread's OpenMP thread count for its lifetime.
class OmpThreads {
 public:
  explicit OmpThreads(int n) : saved_(omp_get_max_threads()) { omp_set_num_threads(n); }
  ~OmpThreads() { omp_set_num_threads(saved_); }
  OmpThreads(const OmpThreads&) = delete;
  OmpThreads& operator=(const OmpThreads&) = delete;

 private:
  int saved_;
};

}  // namespace

const char* pair_method_name(PairMethod m) { return m == PairMethod::kTrack ? "track" : "piv"; }

PairMethod pair_method_from_name(const std::string& name) {
  return core::enum_from_name(name, {PairMethod::kPiv, PairMethod::kTrack}, pair_method_name, "pair method (--method)");
}

void PivJobOptions::validate() const {
  piv.validate();
  if (on_pair && !tracks_output.empty())
    throw ConfigError("tracks: fields handed to the caller take no --tracks file");
  preprocess.validate();
  if (method == PairMethod::kTrack) {
    if (preprocess.any())
      throw ConfigError("--method track takes the frames as they are: no --highpass, --clahe, --background or "
                        "other preprocessing");
    if (track.bead_diameter_px != 0) track.validate();
  }
  if (!tracks_output.empty()) {
    if (method != PairMethod::kTrack) throw ConfigError("--tracks needs --method track");
    if (!io::is_track_file_path(tracks_output))
      throw ConfigError(fmt::format("--tracks {}: expected an .h5 or .csv file", tracks_output.string()));
    if (std::filesystem::weakly_canonical(tracks_output) == std::filesystem::weakly_canonical(output))
      throw ConfigError(fmt::format("--tracks {}: the same file as the output", tracks_output.string()));
  }
  if (!(video_fps >= 0 && std::isfinite(video_fps)))
    throw ConfigError(fmt::format("--fps {}: expected a positive finite frame rate", video_fps));
  if (inputs.empty() && !frames) throw ConfigError("piv: no input given (two images, a glob or a video)");
  const bool csv = io::is_field_csv(output);
  if (!on_pair && !csv && !io::has_extension(output, ".h5") && !io::has_extension(output, ".hdf5"))
    throw ConfigError(fmt::format("{}: output must end in .csv (one pair) or .h5 (any number "
                                  "of pairs)",
                                  output.string()));
  if (csv && !on_pair && !frames) {
    // One pair: exactly two image files. Say what the inputs really are.
    auto is_image = [](const std::string& in) {
      return io::is_readable_image_extension(in) || (std::filesystem::exists(in) && io::looks_like_image(in));
    };
    if (inputs.size() == 1 && (io::is_video_extension(inputs[0]) || io::looks_like_video(inputs[0])))
      throw ConfigError(fmt::format("{}: {} is a video (many pairs); a CSV holds one pair: use an "
                                    ".h5 output",
                                    output.string(), inputs[0]));
    std::size_t files = 0;
    for (const auto& in : inputs)
      files += in.find_first_of("*?[") != std::string::npos && !std::filesystem::exists(in)
                   ? io::expand_glob(in).size()
                   : 1;
    if (inputs.size() != 2)
      throw ConfigError(fmt::format("{}: a CSV holds one pair, i.e. two image files; the input{} "
                                    "give{} {} file{}: use an .h5 output for sequences and videos",
                                    output.string(), inputs.size() == 1 ? "" : "s",
                                    inputs.size() == 1 ? "s" : "", files, files == 1 ? "" : "s"));
    for (const auto& in : inputs) {
      if (!std::filesystem::exists(in)) throw InputError(fmt::format("{}: no such file", in));
      if (!is_image(in))
        throw InputError(fmt::format("{}: not an image: the name and the first bytes match none of "
                                     "the formats read ({})",
                                     in, io::decoded_image_formats()));
    }
  }
  // A pair of spacing s holds s + 1 frames in memory while the clip streams.
  if (pair_spacing < 1 || pair_spacing > 1000)
    throw ConfigError(fmt::format("pair spacing (--spacing) {}: expected 1 to 1000", pair_spacing));
  if (stride < 1) throw ConfigError(fmt::format("stride {}: must be >= 1", stride));
  if (threads < 0 || threads > 1024) throw ConfigError(fmt::format("threads {}: expected 0 (all cores) to 1024", threads));
  if (first_frame < 0) throw ConfigError(fmt::format("first frame {}: must be >= 0", first_frame));
  if (last_frame >= 0 && last_frame < first_frame + pair_spacing)
    throw ConfigError(fmt::format("frame range {}..{} holds no pair of spacing {}", first_frame,
                                  last_frame, pair_spacing));
  if (!(duplicate_tolerance >= 0))
    throw ConfigError(
        fmt::format("duplicate tolerance {}: must be >= 0", format_number(duplicate_tolerance)));
  if (std::isinf(centre_x_px) || std::isinf(centre_y_px))
    throw ConfigError(fmt::format("centre {},{} px: expected finite pixel coordinates",
                                  format_number(centre_x_px), format_number(centre_y_px)));
  for (const auto& [name, v] : {std::pair{"--vane-angle0-deg", vane.angle0_deg}, {"--phi0-rad", vane.phi0_rad},
                                {"--phase-rad", vane.phase_rad}, {"--log-offset-s", vane.log_offset_s}})
    if (!std::isfinite(v))
      throw ConfigError(fmt::format("{} {}: expected a finite number", name, format_number(v)));
  if (!(std::abs(vane.phi0_rad) <= 1000.0))
    throw ConfigError(
        fmt::format("--phi0-rad {}: expected |phi0| <= 1000 rad", format_number(vane.phi0_rad)));
  if (!(vane.f_Hz >= 0 && vane.f_Hz <= 1e6))
    throw ConfigError(fmt::format("vane frequency {} Hz: expected 0 to 1e6 Hz", format_number(vane.f_Hz)));
  const bool need_centre = annulus_outer_px > 0 || vane.geometry.blades > 0;
  if (need_centre && (std::isnan(centre_x_px) || std::isnan(centre_y_px)))
    throw ConfigError("the annulus and vane masks need the cup centre (--centre X,Y in px)");
  if ((annulus_outer_px != 0 || annulus_inner_px != 0) &&
      !(std::isfinite(annulus_outer_px) && annulus_outer_px > annulus_inner_px && annulus_inner_px >= 0))
    throw ConfigError(fmt::format("annulus radii {}..{} px: need 0 <= inner < outer",
                                  format_number(annulus_inner_px), format_number(annulus_outer_px)));
  if (vane.geometry.blades < 0 || vane.geometry.blades > 64)
    throw ConfigError(fmt::format("vane blades {}: must be 0..64", vane.geometry.blades));
  if (vane.geometry.blades > 0 &&
      !(vane.geometry.half_width_px > 0 && vane.geometry.radius_px > vane.geometry.half_width_px))
    throw ConfigError("vane: need half-width > 0 and radius > half-width (px)");
  if (vane.geometry.blades > 0 && vane.log_path.empty() && !(vane.f_Hz >= 0))
    throw ConfigError(fmt::format("vane frequency {} Hz: must be >= 0", format_number(vane.f_Hz)));
  if (!(vane.margin_px >= 0)) throw ConfigError("vane margin: must be >= 0 px");
  if (vane.phase_auto && (vane.geometry.blades == 0 || !vane.log_path.empty() || !(vane.f_Hz > 0)))
    throw ConfigError("--phase-auto finds the phase of the vane's sinusoid: it needs --vane, --f-hz and no --angle-log");
}

namespace {

/// The job's frames: the caller's (PivJobOptions::frames) or `inputs` opened.
std::unique_ptr<io::FrameSource> open_source(const PivJobOptions& o) {
  return o.frames ? o.frames() : io::open_frames(o.inputs, o.fps, o.grey, o.video_fps);
}

/// What the messages name as the input: the first input, or the caller's frames.
std::string input_name(const PivJobOptions& o) { return o.inputs.empty() ? std::string("frames") : o.inputs.front(); }

/// The vane angle seen in each selected frame, relative to angle0 (blade symmetry:
/// within +-pi/blades), with the frame times.
void measure_vane(const PivJobOptions& o, std::vector<double>& ts, std::vector<double>& phis) {
  auto src = open_source(o);
  const double a0 = o.vane.angle0_deg * std::numbers::pi / 180.0;
  const double half = std::numbers::pi / o.vane.geometry.blades;
  io::Frame fr;
  while (src->next(fr)) {
    if (fr.index < o.first_frame) continue;
    if (o.last_frame >= 0 && fr.index > o.last_frame) break;
    ts.push_back(fr.t_s);
    phis.push_back(piv::estimate_vane_angle(fr.gray, o.centre_x_px, o.centre_y_px, o.vane.geometry, a0 - half,
                                            a0 + half) -
                   a0);
  }
  if (ts.empty()) throw InputError(fmt::format("{}: no frame to measure the vane angle in", input_name(o)));
}

/// --phase-auto: the phase of the vane's sinusoid from the angles seen in the frames.
void find_vane_phase(const PivJobOptions& o, piv::VaneDrive& vane_angle, PivJobSummary& sum) {
  std::vector<double> ts, phis;
  measure_vane(o, ts, phis);
  const auto fit = piv::fit_vane_phase(ts, phis, o.vane.f_Hz);
  if (!std::isfinite(fit.phase_rad))
    throw InputError(fmt::format("{}: {} frames span less than a quarter cycle of {} Hz: the vane phase cannot be "
                                 "found; give --phase-rad",
                                 input_name(o), ts.size(), format_number(o.vane.f_Hz)));
  // The fit must see the vane the options describe: an amplitude within 25 % of phi0.
  if (!(std::abs(fit.amplitude_rad - std::abs(o.vane.phi0_rad)) <= 0.25 * std::abs(o.vane.phi0_rad)))
    throw InputError(fmt::format("{}: the vane angle seen in the frames oscillates with amplitude {:.4g} rad, "
                                 "--phi0-rad says {}: expected within 25 %; check --vane, --centre and "
                                 "--vane-angle0-deg, or give --phase-rad",
                                 input_name(o), fit.amplitude_rad, format_number(o.vane.phi0_rad)));
  // phi0 < 0 is the same sinusoid shifted by pi.
  sum.phase_rad = o.vane.phi0_rad < 0 ? std::remainder(fit.phase_rad + std::numbers::pi, 2 * std::numbers::pi)
                                      : fit.phase_rad;
  sum.phase_rms_rad = fit.rms_rad;
  sum.phase_amplitude_rad = fit.amplitude_rad;
  vane_angle.set_phase(sum.phase_rad);
}

/// The angle log aligned with the video: the vane angle measured in each selected frame
/// against the log at t + offset.
void align_angle_log(const PivJobOptions& o, double fps, piv::VaneDrive& vane_angle) {
  std::vector<double> ts, phis;
  measure_vane(o, ts, phis);
  const double off =
      piv::best_log_offset(ts, phis, vane_angle.log_times(), vane_angle.log_angles(), 0.25 / fps);
  if (std::isnan(off))
    throw InputError(fmt::format(
        "{}: the angle log spans {} s, less than the clip's {} s; it "
        "cannot be aligned",
        o.vane.log_path, format_number(vane_angle.log_times().back() - vane_angle.log_times().front()),
        format_number(ts.back() - ts.front())));
  vane_angle.set_log_offset(off);
}

/// The background for subtraction: the temporal median of frames sampled evenly over
/// the selected range (a first, separate read of the source).
cv::Mat background_image(const PivJobOptions& o) {
  auto pre = open_source(o);
  const std::int64_t hint = pre->size_hint();
  const std::int64_t last = o.last_frame >= 0 ? o.last_frame : (hint > 0 ? hint - 1 : -1);
  const std::int64_t span = last >= o.first_frame ? last - o.first_frame + 1 : 0;
  const std::int64_t every = span > 0 ? std::max<std::int64_t>(1, span / o.preprocess.background_frames) : 1;
  std::vector<cv::Mat> sample;
  io::Frame fr;
  while (pre->next(fr) && static_cast<int>(sample.size()) < o.preprocess.background_frames) {
    if (fr.index < o.first_frame || (last >= 0 && fr.index > last)) continue;
    if ((fr.index - o.first_frame) % every == 0) sample.push_back(fr.gray.clone());
  }
  return piv::temporal_median(sample);
}

/// The masks of a frame: static, annulus, vane at the frame's time (255 = masked).
struct FrameMasks {
  const PivJobOptions& o;
  cv::Mat static_mask;
  const piv::VaneDrive& vane_angle;
  /// The whole mask; with `hiding`, also what of it hides beads: the static mask and the
  /// vane (tracking's windows stay clear of it), the vane drawn once for both.
  [[nodiscard]] cv::Mat of(const io::Frame& fr, cv::Mat* hiding = nullptr) const {
    const cv::Mat hides = o.vane.geometry.blades > 0 ? piv::combine_masks(static_mask, vane(fr)) : static_mask;
    if (hiding) *hiding = hides;
    if (o.annulus_outer_px <= 0) return hides;
    return piv::combine_masks(hides, piv::annulus_mask(fr.gray.size(), o.centre_x_px, o.centre_y_px,
                                                       o.annulus_inner_px, o.annulus_outer_px));
  }
  /// Where no bead counts: outside the annulus (empty without one).
  [[nodiscard]] cv::Mat outside(cv::Size size) const {
    if (o.annulus_outer_px <= 0) return {};
    return piv::annulus_mask(size, o.centre_x_px, o.centre_y_px, o.annulus_inner_px, o.annulus_outer_px);
  }
  [[nodiscard]] cv::Mat vane(const io::Frame& fr) const {
    return piv::vane_mask(fr.gray.size(), o.centre_x_px, o.centre_y_px, vane_angle.at(fr.t_s, fr.label),
                          o.vane.geometry, o.vane.margin_px);
  }
};

/// The first frame used, as PIV sees it, and its mask.
struct FirstFrame {
  cv::Mat image, mask;
};

/// The texture's size, measured on the first frame used as PIV sees it (preprocessed,
/// masked): the windows are sized to it and the predictor's smoothing fit chosen by it
/// (unless given), and `profile` bounds how far the footprint a vector averages over
/// moves r_c.
piv::PivOptions options_for_texture(const PivJobOptions& o, const FrameMasks& masks, const cv::Mat& background,
                                    PivJobSummary& sum, FirstFrame& first) {
  piv::PivOptions piv_options = o.piv;
  auto pre = open_source(o);
  io::Frame fr;
  while (pre->next(fr)) {
    if (fr.index < o.first_frame || fr.damaged) continue;
    if (o.last_frame >= 0 && fr.index > o.last_frame) break;
    if (!masks.static_mask.empty() && masks.static_mask.size() != fr.gray.size()) break;  // refused later
    const cv::Mat img = o.preprocess.any() ? piv::preprocess(fr.gray, o.preprocess, background) : fr.gray;
    first = {img, masks.of(fr)};
    sum.texture_half_width_px = piv::texture_half_width_px(img, first.mask);
    if (o.size_windows_to_texture)
      piv_options.windows_px = piv::windows_for_texture(o.piv.windows_px, sum.texture_half_width_px, img.size());
    break;
  }
  if (o.fit_predictor_to_texture) piv_options.predictor_fit = piv::predictor_fit_for_texture(sum.texture_half_width_px);
  sum.windows_px = piv_options.windows_px;
  return piv_options;
}

/// Tracking's options: the bead diameter given, or the texture's (measured by
/// size_windows), the offset from a bead's peak to its disc's centre measured on the
/// first frame, and the grid's cell.
track::TrackOptions track_options(const PivJobOptions& o, PivJobSummary& sum, const FirstFrame& first) {
  track::TrackOptions t = o.track;
  if (t.bead_diameter_px == 0) {
    const double d = sum.texture_half_width_px * piv::kBeadDiameterPerHalfWidth;
    if (!(d >= 3 && d <= 200))
      throw InputError(fmt::format("{}: the texture of the first frame gives no bead size for --method track ({} "
                                   "px; expected 3..200): give --bead-diameter-px",
                                   input_name(o), std::isfinite(d) ? fmt::format("{:.3g}", d) : "none"));
    t.bead_diameter_px = d;
  }
  t.validate();
  if (o.measure_centre_offset && !first.image.empty())
    t.centre_offset_px = track::disc_centre_offset(first.image, first.mask, t);
  sum.track_bead_diameter_px = t.bead_diameter_px;
  sum.track_cell_px = track::grid_cell_px(t.bead_diameter_px);
  return t;
}

/// The pair estimator of the method: PIV's engine, or the beads tracked (clear of what
/// hides them, centres outside the annulus not counted: `outside`) and gridded.
PairEstimator pair_estimator(const PivJobOptions& o, const piv::PivOptions& piv_options,
                             const track::TrackOptions& track_options, int cell_px, const cv::Mat& outside) {
  if (o.method == PairMethod::kTrack)
    return [track_options, cell_px, outside](const Unique& a, const Unique& b) {
      PairResult r;
      r.beads = track::track_pair(a.image, b.image, a.hiding, b.hiding, track_options, outside);
      r.piv.field = track::beads_to_grid(r.beads, a.image.size(), cell_px, a.mask);
      return r;
    };
  auto engine = std::make_shared<const piv::PivEngine>(piv_options);
  return [engine](const Unique& a, const Unique& b) {
    return PairResult{engine->process(a.image, b.image, a.mask, b.mask), {}};
  };
}

/// PIV's part of the header: its options, how the windows were chosen, the footprint.
void add_piv_window_metadata(core::Metadata& meta, const PivJobOptions& o, const piv::PivOptions& piv_options,
                             const PivJobSummary& sum) {
  for (auto& kv : piv_options.to_metadata()) meta.push_back(std::move(kv));
  if (o.size_windows_to_texture)
    meta.emplace_back(
        "piv_windows_rule",
        std::isfinite(sum.texture_half_width_px)
            ? fmt::format("sized to the texture: autocorrelation half-width {:.3g} px (shaded beads: about {:.3g} px "
                          "across) in the first frame; the windows {} scaled by a power of two so that the final "
                          "window is at least {} half-widths{}",
                          sum.texture_half_width_px, sum.texture_half_width_px * piv::kBeadDiameterPerHalfWidth,
                          fmt::join(o.piv.windows_px, ","), format_number(piv::kFinalWindowPerHalfWidth),
                          piv_options.windows_px.size() > o.piv.windows_px.size()
                              ? fmt::format("; passes of half the final window added (beads of {} px or more: a "
                                            "final window at most {} beads wide, at least {} px)",
                                            format_number(piv::kSmallBeadMinPx),
                                            format_number(piv::kMaxFinalWindowBeads), piv::kMinFinalWindowPx)
                              : std::string())
            : fmt::format("the windows {} as given: the texture size could not be measured in the first frame",
                          fmt::join(o.piv.windows_px, ",")));
  else
    meta.emplace_back("piv_windows_rule", "as given");
  if (piv_options.predictor_smoothing <= 0) {
    meta.emplace_back("piv_predictor_smoothing_fit_rule", "none: the predictor is not smoothed (smoothing 0)");
  } else if (o.fit_predictor_to_texture) {
    const double bead_px = sum.texture_half_width_px * piv::kBeadDiameterPerHalfWidth;
    meta.emplace_back(
        "piv_predictor_smoothing_fit_rule",
        !std::isfinite(bead_px)
            ? std::string("gaussian: the texture size could not be measured in the first frame")
            : fmt::format("from the texture: {} (shaded beads of about {:.3g} px across; quadratic from {} px, "
                          "beads; gaussian below, seeded particles)",
                          piv::predictor_fit_name(piv_options.predictor_fit), bead_px,
                          format_number(piv::kSmallBeadMinPx)));
  } else {
    meta.emplace_back("piv_predictor_smoothing_fit_rule", "as given");
  }
  // What a vector is a mean over: `profile` reads these (root attributes of .h5 fields).
  meta.emplace_back("piv_final_window_px", std::to_string(piv_options.windows_px.back()));
  if (std::isfinite(sum.texture_half_width_px))
    meta.emplace_back("texture_size_px",
                      fmt::format("{:.4g}", sum.texture_half_width_px * piv::kBeadDiameterPerHalfWidth));
}

/// Tracking's part of the header: the tracker's options and the grid.
void add_track_metadata(core::Metadata& meta, const track::TrackOptions& tracking, const PivJobSummary& sum,
                        bool diameter_given, bool offset_measured) {
  for (auto& kv : tracking.to_metadata()) meta.push_back(std::move(kv));
  meta.emplace_back("track_bead_diameter_rule",
                    diameter_given ? std::string("as given (--bead-diameter-px)")
                                   : fmt::format("the texture of the first frame: autocorrelation half-width {:.3g} "
                                                 "px x {:.3g}",
                                                 sum.texture_half_width_px, piv::kBeadDiameterPerHalfWidth));
  meta.emplace_back("track_centre_offset_rule",
                    offset_measured ? fmt::format("measured on the first frame: the circle of the bead's diameter that "
                                                  "best separates its mean bead from the surroundings (0,0 where "
                                                  "fewer than {} beads lie clear of masks and the edge)",
                                                  track::kMinOffsetBeads)
                                    : std::string("as given (--disc-offset-px)"));
  meta.emplace_back("track_grid",
                    fmt::format("cells of {} px (half a bead); a valid vector is the mean displacement of the beads "
                                "whose frame-a centre lies in its cell (beads count where their centre lies in the "
                                "annulus, a quarter bead clear of the vane and a mask image); masked: under a mask "
                                "or no bead; invalid: "
                                "its beads lost or back more than {} px from where they started; peak and "
                                "peak_ratio 0 (no correlation)",
                                sum.track_cell_px, format_number(tracking.fb_tolerance_px)));
  // What a vector is a mean over: `profile` reads it (a root attribute of .h5 fields).
  meta.emplace_back("track_cell_px", std::to_string(sum.track_cell_px));
}

/// The header of the fields: source, the method's options (PIV: how the windows were
/// chosen; tracking: the bead size and the grid), preprocessing, pairs, masks.
core::Metadata piv_metadata(const PivJobOptions& o, const core::Metadata& header, const io::FrameSource& source,
                            const piv::PivOptions& piv_options, const track::TrackOptions& tracking,
                            const piv::VaneDrive& vane_angle, const PivJobSummary& sum) {
  core::Metadata meta = header;
  meta.emplace_back("source", source.description());
  meta.emplace_back("grey_conversion", io::grey_mode_name(o.grey));
  if (o.method == PairMethod::kTrack) {  // (absent: piv, as in the files written before tracking)
    meta.emplace_back("pair_method", pair_method_name(o.method));
    add_track_metadata(meta, tracking, sum, o.track.bead_diameter_px != 0, o.measure_centre_offset);
  } else {
    add_piv_window_metadata(meta, o, piv_options, sum);
  }
  for (auto& kv : o.preprocess.to_metadata()) meta.push_back(std::move(kv));
  meta.emplace_back("pairs", fmt::format("unique frames (i, i+{}), stride {}, frames {}..{}", o.pair_spacing,
                                         o.stride, o.first_frame,
                                         o.last_frame < 0 ? std::string("end") : std::to_string(o.last_frame)));
  if (o.annulus_outer_px > 0)
    meta.emplace_back("mask_annulus",
                      fmt::format("centre ({}, {}) px, r in [{}, {}] px measured", format_number(o.centre_x_px),
                                  format_number(o.centre_y_px), format_number(o.annulus_inner_px),
                                  format_number(o.annulus_outer_px)));
  if (!o.mask_image.empty()) meta.emplace_back("mask_image", o.mask_image);
  if (o.vane.geometry.blades > 0)
    meta.emplace_back(
        "mask_vane",
        fmt::format(
            "{} blades, half-width {} px, radius {} px, margin {} px, "
            "angle0 {} deg, phi(t) = {}",
            o.vane.geometry.blades, format_number(o.vane.geometry.half_width_px),
            format_number(o.vane.geometry.radius_px), format_number(o.vane.margin_px),
            format_number(o.vane.angle0_deg),
            o.vane.log_path.empty()
                ? fmt::format("{} sin(2 pi {} t + {}){}", format_number(o.vane.phi0_rad),
                              format_number(o.vane.f_Hz), format_number(vane_angle.phase()),
                              o.vane.phase_auto
                                  ? fmt::format(" (phase found from the video: rms residual {:.3g} rad)", sum.phase_rms_rad)
                                  : "")
                : fmt::format("log {} at t + {} s{}", o.vane.log_path, format_number(vane_angle.log_offset()),
                              o.vane.log_offset_auto ? " (offset found from the video)" : "")));
  meta.emplace_back("units", "displacements in px per pair from frame a to frame b");
  return meta;
}

/// fields.h5's root attributes: what profile and width read (docs/formats.md); a
/// tracks file carries the same.
template <class Writer>
void set_field_attributes(Writer& fields, const PivJobOptions& o, const io::FrameSource& source,
                          const core::Metadata& meta, const piv::PivOptions& piv_options,
                          const piv::VaneDrive& vane_angle, const PivJobSummary& sum) {
  fields.set_attribute("fps", source.fps());
  fields.set_attribute("source", source.description());
  fields.set_attribute("options", metadata_text(meta));
  std::string conv;
  for (const auto& [k, v] : core::convention_metadata()) conv += k + ": " + v + "\n";
  fields.set_attribute("conventions", conv);
  fields.set_attribute("shearzone_version", kVersion);
  if (o.method == PairMethod::kTrack) {
    fields.set_attribute("pair_method", std::string(pair_method_name(o.method)));
    fields.set_attribute("track_cell_px", static_cast<double>(sum.track_cell_px));
    fields.set_attribute("track_bead_diameter_px", sum.track_bead_diameter_px);
  } else {
    fields.set_attribute("piv_final_window_px", static_cast<double>(piv_options.windows_px.back()));
    if (std::isfinite(sum.texture_half_width_px))
      fields.set_attribute("texture_size_px", sum.texture_half_width_px * piv::kBeadDiameterPerHalfWidth);
  }
  fields.set_attribute("duplicates_skipped", static_cast<std::int64_t>(sum.duplicates));
  fields.set_attribute("damaged_frames_skipped", static_cast<std::int64_t>(sum.damaged.size()));
  {
    std::string list;
    for (std::size_t i = 0; i < sum.damaged.size() && i < 1000; ++i) {
      if (i) list += ',';  // (not "," + to_string: GCC 12 -Wrestrict false positive)
      list += std::to_string(sum.damaged[i]);
    }
    if (sum.damaged.size() > 1000) list += ",...";
    fields.set_attribute("damaged_frames", list.empty() ? std::string("none") : list);
  }
  // The drive the vane mask followed: what `profile` locks its phase to.
  if (o.vane.geometry.blades > 0 && o.vane.log_path.empty() && o.vane.f_Hz > 0)
    fields.set_attribute("vane_phase_rad", vane_angle.phase());
  if (o.vane.geometry.blades > 0 && !o.vane.log_path.empty()) {
    fields.set_attribute("vane_angle_log", o.vane.log_path);
    fields.set_attribute("vane_log_offset_s", vane_angle.log_offset());
  }
  if (!std::isnan(o.centre_x_px)) {
    fields.set_attribute("centre_x_px", o.centre_x_px);
    fields.set_attribute("centre_y_px", o.centre_y_px);
  }
  for (const auto& [k, v] : o.attributes) {
    double x = 0;
    if (io::parse_number(v, false, x)) fields.set_attribute(k, x);
    else fields.set_attribute(k, v);
  }
}

}  // namespace

PivJobSummary run_piv_job(const PivJobOptions& o, const core::Metadata& header,
                          const core::ProgressCallback& progress) {
  const auto t_start = std::chrono::steady_clock::now();
  // Step 1: everything cheap first: options, output rule, inputs, masks, the log.
  o.validate();
  if (!o.on_pair) io::check_output_allowed(o.output, o.force);
  if (!o.tracks_output.empty()) io::check_output_allowed(o.tracks_output, o.force);
  auto source = open_source(o);
  cv::Mat static_mask;
  if (!o.mask_image.empty()) {
    cv::compare(io::read_image_gray(o.mask_image), 0, static_mask, cv::CMP_NE);  // 255 = masked
  }
  piv::VaneDrive vane_angle({o.vane.angle0_deg, o.vane.phi0_rad, o.vane.f_Hz, o.vane.phase_rad, o.vane.log_path,
                             o.vane.log_offset_s});
  PivJobSummary sum;
  sum.phase_rad = o.vane.phase_rad;
  if (o.vane.phase_auto) find_vane_phase(o, vane_angle, sum);
  if (o.vane.geometry.blades > 0 && !o.vane.log_path.empty() && o.vane.log_offset_auto)
    align_angle_log(o, source->fps(), vane_angle);
  const cv::Mat background = o.preprocess.background ? background_image(o) : cv::Mat();
  const FrameMasks masks{o, static_mask, vane_angle};
  FirstFrame first;
  const piv::PivOptions piv_options = options_for_texture(o, masks, background, sum, first);
  const track::TrackOptions tracking = o.method == PairMethod::kTrack ? track_options(o, sum, first) : o.track;
  const PairEstimator estimate = pair_estimator(
      o, piv_options, tracking, sum.track_cell_px,
      o.method == PairMethod::kTrack && !first.image.empty() ? masks.outside(first.image.size()) : cv::Mat());
  const bool csv = !o.on_pair && io::is_field_csv(o.output);

  // Step 2: stream the frames; keep the unique frames a pair still needs.
  std::deque<std::shared_ptr<const Unique>> window;  // the last pair_spacing + 1 unique frames
  std::size_t unique_count = 0;
  // The output (none when the caller takes the fields): .h5 created with the first pair.
  std::optional<io::AtomicOutput> out;
  std::optional<io::FieldFileWriter> fields;
  if (!o.on_pair) {
    out.emplace(o.output, o.force);
    fields.emplace(out->temp_path());
  }
  const core::Metadata meta = piv_metadata(o, header, *source, piv_options, tracking, vane_angle, sum);
  // Tracks: the beads of each pair, linked, written as the pairs are.
  std::unique_ptr<io::AtomicOutput> tracks_out;
  std::unique_ptr<io::TrackFileWriter> tracks;
  track::Linker linker(o.method == PairMethod::kTrack ? tracking.bead_diameter_px : 1.0);
  if (!o.tracks_output.empty()) {
    tracks_out = std::make_unique<io::AtomicOutput>(o.tracks_output, o.force);
    tracks = std::make_unique<io::TrackFileWriter>(tracks_out->temp_path(), meta);
  }

  std::size_t pair_index = 0;
  const std::int64_t hint = source->size_hint();
  const std::size_t est_pairs =
      hint > 0 ? static_cast<std::size_t>(std::max<std::int64_t>(0, (hint - 1 - o.pair_spacing) / o.stride + 1)) : 0;
  // Threads: a stream of pairs runs one pair per thread (everything of a pair
  // parallel, the decoding of the next frames overlapping); a single pair runs its
  // windows in parallel.
  sum.threads = o.threads > 0 ? o.threads : omp_get_max_threads();
  sum.pairs_in_parallel = sum.threads > 1 && !csv && (hint <= 0 || est_pairs >= 2);
  const OmpThreads omp_threads(sum.pairs_in_parallel ? 1 : sum.threads);
  std::unique_ptr<PairPool> pool;
  if (sum.pairs_in_parallel)  // one pair per thread, its windows serial
    pool = std::make_unique<PairPool>(
        [&estimate](PairJob& j) { j.result = estimate(*j.a, *j.b); }, sum.threads,
        [] { omp_set_num_threads(1); });

  // Step 3: write a finished pair.
  auto write_pair = [&](const Unique& a, const Unique& b, const PairResult& pair) {
    const piv::PivResult& r = pair.piv;
    const core::VectorField& f = r.field;
    const double dt = b.frame.t_s - a.frame.t_s;
    if (o.method == PairMethod::kTrack) {
      const core::TrackedBeads rows = linker.link(pair.beads, a.frame.index, b.frame.index, a.frame.t_s, dt);
      sum.beads += rows.size();
      sum.beads_tracked += pair.beads.tracked();
      if (tracks) tracks->append(rows);
    }
    sum.vectors_per_pair = f.size();
    sum.valid += f.count(core::VectorFlag::kValid);
    sum.replaced += f.count(core::VectorFlag::kReplaced);
    sum.masked += f.count(core::VectorFlag::kMasked);
    sum.invalid += f.count(core::VectorFlag::kInvalid);
    sum.coarse_predictor_pairs += r.coarse_predictor;
    sum.refused_pairs += r.coarse_refused;
    if (std::isfinite(r.coarse_max_displacement_px))
      sum.coarse_max_displacement_px = std::max(sum.coarse_max_displacement_px, r.coarse_max_displacement_px);
    if (o.on_pair) {
      o.on_pair(f, a.frame, b.frame, meta);
    } else if (csv) {
      core::Metadata m2 = meta;
      m2.emplace_back("frame_a", a.frame.label);
      m2.emplace_back("frame_b", b.frame.label);
      m2.emplace_back("t_a_s", format_number(a.frame.t_s));
      m2.emplace_back("dt_s", format_number(dt));
      io::write_field_csv(out->stream(), m2, f);
    } else {
      fields->append(f, a.frame.index, b.frame.index, a.frame.t_s, dt);
    }
    ++pair_index;
    ++sum.pairs;
    if (progress) progress(pair_index, std::max(est_pairs, pair_index));
  };
  auto write_done = [&](std::optional<PairJob> j) {  // a finished pair, if any
    if (j) write_pair(*j->a, *j->b, j->result);
    return j.has_value();
  };

  io::Frame frame;
  while (source->next(frame)) {
    ++sum.frames_read;
    if (frame.index < o.first_frame) continue;
    if (o.last_frame >= 0 && frame.index > o.last_frame) break;
    // A frame FFmpeg had to conceal holds invented pixels: never measured. The pair
    // then spans the gap (its dt from the timestamps), as for repeated frames.
    if (frame.damaged) {
      sum.damaged.push_back(frame.index);
      continue;
    }
    if (!window.empty() && frames_equal(window.back()->frame.gray, frame.gray, o.duplicate_tolerance)) {
      ++sum.duplicates;
      continue;
    }
    if (!static_mask.empty() && static_mask.size() != frame.gray.size())
      throw InputError(fmt::format("{}: mask is {}x{}; the frames are {}x{}", o.mask_image,
                                   static_mask.cols, static_mask.rows, frame.gray.cols,
                                   frame.gray.rows));
    auto up = std::make_shared<Unique>();
    Unique& u = *up;
    u.frame = frame;
    u.frame.gray = frame.gray.clone();
    u.image = o.preprocess.any() ? piv::preprocess(frame.gray, o.preprocess, background) : u.frame.gray;
    u.mask = masks.of(frame, o.method == PairMethod::kTrack ? &u.hiding : nullptr);
    window.push_back(std::move(up));
    ++unique_count;
    if (window.size() > static_cast<std::size_t>(o.pair_spacing) + 1) window.pop_front();
    if (window.size() < static_cast<std::size_t>(o.pair_spacing) + 1) continue;
    const std::size_t start = unique_count - 1 - static_cast<std::size_t>(o.pair_spacing);
    if (start % static_cast<std::size_t>(o.stride) != 0) continue;

    // One pair: on the pool (written when done, in order) or here.
    const Unique& a = *window.front();
    const Unique& b = *window.back();
    if (a.frame.gray.size() != b.frame.gray.size())
      throw InputError(fmt::format("{}: frame size {}x{} differs from {} ({}x{})", b.frame.label,
                                   b.frame.gray.cols, b.frame.gray.rows, a.frame.label,
                                   a.frame.gray.cols, a.frame.gray.rows));
    if (pool) {
      while (pool->full()) write_done(pool->pop_done(true));
      pool->submit({window.front(), window.back(), {}});
      while (write_done(pool->pop_done(false))) {
      }
    } else {
      write_pair(a, b, estimate(a, b));
    }
  }
  if (pool)
    while (write_done(pool->pop_done(true))) {
    }
  if (sum.pairs == 0)
    throw InputError(fmt::format("{}: no frame pair to process ({} frames read, {} duplicates, "
                                 "pair spacing {}, frames {}..{})",
                                 input_name(o), sum.frames_read, sum.duplicates,
                                 o.pair_spacing, o.first_frame,
                                 o.last_frame < 0 ? std::string("end") : std::to_string(o.last_frame)));

  // Step 4: root attributes and commit.
  if (fields && fields->started()) {
    set_field_attributes(*fields, o, *source, meta, piv_options, vane_angle, sum);
    fields->close();
  }
  if (tracks) {
    set_field_attributes(*tracks, o, *source, meta, piv_options, vane_angle, sum);
    tracks->close();
    tracks_out->commit();
  }
  if (out) out->commit();
  sum.tracks = linker.tracks();
  sum.beads_linkable = linker.linkable();
  sum.beads_linked = linker.linked();
  sum.log_offset_s = vane_angle.log_offset();
  sum.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return sum;
}

}  // namespace shearzone::pipeline
