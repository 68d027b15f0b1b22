// `shearzone piv`: multipass PIV of an image pair, an image sequence or a video.
// Flags map onto pipeline::PivJobOptions; --config FILE.toml sets them by long name.
#include <cmath>
#include <cstdio>
#include <memory>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/core/unset.hpp"
#include "shearzone/pipeline/piv_job.hpp"
#include "shearzone/piv/texture.hpp"
#include "subcommands.hpp"

namespace shearzone::apps {
namespace {

struct PivCli {
  pipeline::PivJobOptions job;
  std::string output;
  std::string tracks;
  std::string config;
  std::string interpolation = "bspline5";
  std::string subpixel = "gauss3";
  std::string residual = "gradient";
  std::string smoothing_fit = "auto";
  std::string method = "piv";
  std::string grey = "luma";
  std::string preset;
  bool no_deform = false;
  bool no_coarse = false;
  std::vector<double> centre, annulus, vane, disc_offset;
  std::vector<std::string> attrs;
  double m_per_px = core::kUnset, n_chain = core::kUnset;
};

int run_piv(CLI::App& c, PivCli& s, const Context& ctx) {
  configure(c, s.config, {"output"});
  auto& j = s.job;
  j.output = s.output;
  j.tracks_output = s.tracks;
  if (!s.preset.empty()) {
    // The preset sets what the command line and the config file leave unset.
    const piv::PivPreset& pr = piv::piv_preset(s.preset);
    if (c.count("--windows") == 0) j.piv.windows_px = pr.windows_px;
    if (c.count("--repeats") == 0) j.piv.final_pass_repeats = pr.final_pass_repeats;
    if (c.count("--interpolation") == 0) s.interpolation = piv::interpolation_name(pr.interpolation);
    if (c.count("--subpixel") == 0) s.subpixel = piv::subpixel_name(pr.subpixel);
    if (c.count("--smoothing") == 0) j.piv.predictor_smoothing = pr.predictor_smoothing;
  }
  j.piv.interpolation = piv::interpolation_from_name(s.interpolation);
  j.piv.subpixel = piv::subpixel_from_name(s.subpixel);
  j.piv.residual = piv::residual_from_name(s.residual);
  j.fit_predictor_to_texture = s.smoothing_fit == "auto";
  if (!j.fit_predictor_to_texture) j.piv.predictor_fit = piv::predictor_fit_from_name(s.smoothing_fit);
  j.method = pipeline::pair_method_from_name(s.method);
  if (j.method != pipeline::PairMethod::kTrack)
    for (const char* opt : {"--bead-diameter-px", "--fb-tolerance-px", "--track-levels", "--tracks", "--disc-offset-px"})
      if (c.count(opt)) throw ConfigError(fmt::format("{} applies to --method track", opt));
  j.size_windows_to_texture = c.count("--windows") == 0;
  j.video_fps = c.count("--fps") > 0 ? j.fps : 0.0;
  j.piv.deform = !s.no_deform;
  j.piv.coarse_estimate = !s.no_coarse;
  j.grey = io::grey_mode_from_name(s.grey);
  if (!s.disc_offset.empty()) {
    j.track.centre_offset_px = {s.disc_offset[0], s.disc_offset[1]};
    j.measure_centre_offset = false;
  }
  if (!s.centre.empty()) {
    j.centre_x_px = s.centre[0];
    j.centre_y_px = s.centre[1];
  }
  if (!s.annulus.empty()) {
    j.annulus_inner_px = s.annulus[0];
    j.annulus_outer_px = s.annulus[1];
  }
  if (!s.vane.empty()) {
    if (s.vane[0] != std::floor(s.vane[0]) || s.vane[0] < 1)
      throw ConfigError(fmt::format("--vane: blade count {} must be a positive integer", s.vane[0]));
    j.vane.geometry = {static_cast<int>(s.vane[0]), s.vane[1], s.vane[2]};
  }
  if (!std::isnan(s.m_per_px) && !(s.m_per_px > 0 && std::isfinite(s.m_per_px)))
    throw ConfigError(fmt::format("--m-per-px {}: expected a finite scale > 0 m per px", s.m_per_px));
  if (!std::isnan(s.n_chain) && !(s.n_chain >= 1 && s.n_chain <= 1e9 && s.n_chain == std::floor(s.n_chain)))
    throw ConfigError(fmt::format("--N {}: expected a whole chain length from 1 to 1e9", s.n_chain));
  if (!std::isnan(s.m_per_px)) j.attributes.emplace_back("m_per_px", fmt::format("{}", s.m_per_px));
  if (!std::isnan(s.n_chain)) j.attributes.emplace_back("N", fmt::format("{}", s.n_chain));
  if (c.count("--f-hz")) j.attributes.emplace_back("f_Hz", fmt::format("{}", j.vane.f_Hz));
  if (c.count("--phi0-rad")) j.attributes.emplace_back("phi0_rad", fmt::format("{}", j.vane.phi0_rad));
  for (auto& kv : parse_key_values(s.attrs, "--attr")) j.attributes.push_back(std::move(kv));

  if (ctx.capture) {  // the Python module's arrays: the options, no file
    ctx.capture(j);
    return kExitOk;
  }
  if (ctx.check_options) {  // the study's option check: no file read
    j.validate();
    return kExitOk;
  }
  core::ProgressReporter progress("piv: pairs", ctx.level);
  const auto sum = pipeline::run_piv_job(j, ctx.header(), progress.callback());
  progress.finish();
  // A bead texture too small for the closed loop to hold (subcommands.hpp): the
  // figures measured on rendered cups, on stderr.
  const double texture_px = sum.texture_half_width_px * piv::kBeadDiameterPerHalfWidth;
  if (j.method == pipeline::PairMethod::kPiv && std::isfinite(texture_px) && texture_px >= piv::kSmallBeadMinPx &&
      texture_px < kSmallTexturePx)
    note_small_beads("piv", "the texture reads as beads of about", texture_px,
                     "with H.264, film at 15 px per bead or more where r_c matters");
  // Tracking is a first version: what the closed loop measured, every time (docs/track.md).
  if (j.method == pipeline::PairMethod::kTrack)
    std::fprintf(stderr,
                 "piv: note: --method track is a first version: on rendered cups its r_c read within 0.15 bead "
                 "diameters of the camera's at 15-50 px per bead with MPEG-4, up to 0.34 low with H.264, up to 0.63 "
                 "off at 8 px, and another status than the camera's in 3 of 108 rows (docs/track.md, \"The closed "
                 "loop\"); compare with --method piv where r_c matters\n");
  if (ctx.level != core::LogLevel::kQuiet) {
    const double n = static_cast<double>(sum.pairs * sum.vectors_per_pair);
    std::string damaged;
    for (std::size_t i = 0; i < sum.damaged.size() && i < 20; ++i) {
      if (i) damaged += ',';
      damaged += std::to_string(sum.damaged[i]);
    }
    if (sum.damaged.size() > 20) damaged += ",...";
    std::printf("piv: %zu pair%s (%zu frames read, %zu duplicates skipped%s) -> %s\n", sum.pairs,
                sum.pairs == 1 ? "" : "s", sum.frames_read, sum.duplicates,
                sum.damaged.empty()
                    ? ""
                    : fmt::format(", {} damaged frame{} skipped: {}", sum.damaged.size(),
                                  sum.damaged.size() == 1 ? "" : "s", damaged)
                          .c_str(),
                j.output.string().c_str());
    std::printf("piv: %zu vectors per pair: %.1f%% valid, %.1f%% replaced, %.1f%% masked, %.1f%% "
                "invalid; %.2f s (%.2f pairs/s)\n",
                sum.vectors_per_pair, 100.0 * sum.valid / n, 100.0 * sum.replaced / n,
                100.0 * sum.masked / n, 100.0 * sum.invalid / n, sum.seconds,
                sum.pairs / std::max(sum.seconds, 1e-9));
    if (j.method == pipeline::PairMethod::kTrack)
      std::printf("piv: beads of %.3g px tracked (%s), one vector per cell of %d px holding a bead\n",
                  sum.track_bead_diameter_px, j.track.bead_diameter_px != 0 ? "as given" : "from the texture",
                  sum.track_cell_px);
    if (j.method == pipeline::PairMethod::kTrack && sum.pairs > 0) {
      auto pct = [](std::size_t a, std::size_t b) { return 100.0 * static_cast<double>(a) / static_cast<double>(std::max<std::size_t>(b, 1)); };
      std::printf("piv: %.1f beads per pair, %.1f%% tracked; %s; %lld tracks%s\n",
                  static_cast<double>(sum.beads) / static_cast<double>(sum.pairs), pct(sum.beads_tracked, sum.beads),
                  sum.beads_linkable > 0
                      ? fmt::format("{:.1f}% of the beads of a pair continue a track of the pair before",
                                    pct(sum.beads_linked, sum.beads_linkable)).c_str()
                      : "no pair continues another (tracks need --stride equal to --spacing)",
                  static_cast<long long>(sum.tracks),
                  j.tracks_output.empty() ? "" : (" -> " + j.tracks_output.string()).c_str());
    }
    const int w0 = sum.windows_px.empty() ? 0 : sum.windows_px.front();
    if (sum.coarse_predictor_pairs > 0)
      std::printf("piv: %zu pair%s moved more than a quarter of the first window (%d px; coarse estimate up "
                  "to %.0f px): the coarse field was their first pass's predictor\n",
                  sum.coarse_predictor_pairs, sum.coarse_predictor_pairs == 1 ? "" : "s", w0,
                  sum.coarse_max_displacement_px);
    if (sum.refused_pairs > 0)
      std::fprintf(stderr,
                   "shearzone: warning: %zu of %zu pairs refused (every vector invalid): under a quarter "
                   "of the coarse templates matched within +-%d px (displacements beyond one first "
                   "window: give larger --windows; or unrelated frames)\n",
                   sum.refused_pairs, sum.pairs, w0);
    if (j.vane.log_offset_auto)
      std::printf("piv: angle log offset found from the video: %.3f s\n", sum.log_offset_s);
    if (j.vane.phase_auto)
      std::printf("piv: vane phase found from the video: %.4f rad (amplitude %.4f rad, rms residual %.2g rad)\n",
                  sum.phase_rad, sum.phase_amplitude_rad, sum.phase_rms_rad);
  }
  return kExitOk;
}

}  // namespace

std::vector<Subcommand> add_piv(CLI::App& root, Context& ctx) {
  auto s = std::make_shared<PivCli>();
  auto& j = s->job;
  auto& p = j.piv;
  CLI::App* c = root.add_subcommand(
      "piv", "Multipass PIV of an image pair, an image sequence or a video -> CSV or HDF5");
  c->add_option("inputs", j.inputs, "Two images, a glob (quote it) or image list, or one video")
      ->required();
  c->add_option("-o,--output", s->output, "Output: .csv (one pair) or .h5 (any number of pairs)");
  c->add_option("--config", s->config, "TOML file setting any of these options by long name");
  c->add_flag("--force", j.force, "Replace an existing output");
  // The method
  c->add_option("--method", s->method,
                "How each pair is measured: piv (windows correlated) or track (each bead tracked on its own by "
                "Lucas-Kanade, put on a grid of half-bead cells; docs/track.md)")
      ->check(CLI::IsMember({"piv", "track"}))
      ->capture_default_str();
  c->add_option("--bead-diameter-px", j.track.bead_diameter_px,
                "--method track: the beads' diameter in the image, px (default: from the first frame's texture); "
                "range: 3..200");
  c->add_option("--fb-tolerance-px", j.track.fb_tolerance_px,
                "--method track: keep a bead when tracking it back lands within this, px; range: 0..10")
      ->capture_default_str();
  c->add_option("--tracks", s->tracks,
                "--method track: also write every bead of every pair, linked into tracks, to this .h5 or .csv "
                "(track id, frames, centre, displacement, velocity, flags; docs/track.md)");
  c->add_option("--disc-offset-px", s->disc_offset,
                "--method track: from a bead's smoothed peak (its lit side) to its disc's centre, X,Y px (default: "
                "measured on the first frame's beads; 0,0 for beads lit along the camera's axis); range: within half "
                "a bead")
      ->expected(2)
      ->delimiter(',');
  c->add_option("--track-levels", j.track.pyramid_levels,
                "--method track: pyramid levels (displacements up to about 3/8 bead x 2^levels); range: 0..6")
      ->capture_default_str();
  // Correlation
  std::string preset_help = "Named setting of windows, interpolation, peak fit, repeats and predictor "
                            "smoothing (options given explicitly win):";
  std::vector<std::string> preset_names;
  for (const auto& pr : piv::piv_presets()) {
    preset_help += fmt::format(" {}: {};", pr.name, pr.summary);
    preset_names.push_back(fmt::format("{}", pr.name));
  }
  preset_help.pop_back();
  c->add_option("--preset", s->preset, preset_help)->check(CLI::IsMember(preset_names));
  c->add_option("--windows", p.windows_px,
                "Window size per pass, px, coarse to fine; range: each a power of two in "
                "8..256, non-increasing, 1 to 8 passes")
      ->delimiter(',')
      ->capture_default_str();
  c->add_option("--overlap", p.overlap, "Window overlap, fraction; range: 0..0.875")
      ->capture_default_str();
  c->add_option("--repeats", p.final_pass_repeats,
                "Extra iterations of the final pass; range: 0..10")
      ->capture_default_str();
  c->add_option("--interpolation", s->interpolation,
                "Image deformation: bilinear, bicubic, bspline, bspline5")
      ->capture_default_str();
  c->add_flag("--no-deform", s->no_deform, "Shift windows by whole pixels instead of deforming");
  c->add_option("--subpixel", s->subpixel, "Peak fit: gauss3 or gauss2d")->capture_default_str();
  c->add_option("--residual", s->residual,
                 "Residual estimator after the first pass: gradient (a Gauss-Newton step on the "
                 "deformed windows) or peak (the correlation peak; reads broad bead textures low)")
      ->check(CLI::IsMember({"gradient", "peak"}))
      ->capture_default_str();
  c->add_option("--search", p.restricted_search,
                "Peak search radius after the first pass, fraction of the window; range: 0.05..0.5")
      ->capture_default_str();
  c->add_flag("--no-coarse", s->no_coarse,
              "No coarse estimate before the first pass (by default, templates of the first "
              "window matched at half resolution within +-1 window give the first pass its "
              "predictor where they find displacements above a quarter window)");
  c->add_option("--smoothing", p.predictor_smoothing,
                "Predictor smoothing between passes, grid steps (0: off); range: 0..5")
      ->capture_default_str();
  c->add_option("--smoothing-fit", s->smoothing_fit,
                "Shape of the predictor smoothing: gaussian (sigma --smoothing steps), quadratic (a "
                "least-squares quadratic over +-max(2, 2 x --smoothing) steps: keeps a steep profile's "
                "curvature, less bias on bead profiles, more scatter on seeded particles) or auto (quadratic "
                "where the first frame's texture reads as beads of 6.5 px or more, else gaussian)")
      ->check(CLI::IsMember({"auto", "gaussian", "quadratic"}))
      ->capture_default_str();
  // Validation
  c->add_option("--median-threshold", p.median_threshold,
                "Normalised median test threshold (0: off); range: -1e9..1e9")
      ->capture_default_str();
  c->add_option("--median-epsilon", p.median_epsilon_px,
                "Normalised median test noise level, px; range: 0..10")
      ->capture_default_str();
  c->add_option("--median-radius", p.median_radius,
                "Median neighbourhood radius in vectors; range: 1..3")
      ->capture_default_str();
  c->add_option("--std-threshold", p.std_threshold,
                "Global std filter k (0: off); range: -1e9..1e9")
      ->capture_default_str();
  c->add_option("--max-displacement", p.max_displacement_px, "Global limit on |d|, px; range: > 0")
      ->capture_default_str();
  c->add_option("--min-peak", p.min_peak,
                "Peak-height threshold: a vector peaking below min(this, --min-peak-relative x the "
                "pair's median peak) is invalid; range: 0..1")
      ->capture_default_str();
  c->add_option("--min-peak-relative", p.min_peak_relative,
                "Fraction of the pass's median correlation peak (0: --min-peak alone); range: 0..1")
      ->capture_default_str();
  c->add_option("--min-peak-ratio", p.min_peak_ratio,
                "Smallest first/second peak ratio; range: 1..100")
      ->capture_default_str();
  c->add_option("--min-window-std", p.min_window_std,
                "Smallest window intensity std, fraction of full scale; range: 0..0.5")
      ->capture_default_str();
  // Preprocessing
  c->add_flag("--background", j.preprocess.background,
              "Subtract the temporal median of the clip (static background)");
  c->add_option("--background-frames", j.preprocess.background_frames,
                "Frames sampled for the background median; range: 3..500")
      ->capture_default_str();
  c->add_option("--intensity-cap", j.preprocess.intensity_cap,
                "Cap intensities at median + k std (0: off); range: >= 0")
      ->capture_default_str();
  c->add_flag("--clahe", j.preprocess.clahe, "Contrast-limited adaptive histogram equalisation");
  c->add_option("--clahe-tile", j.preprocess.clahe_tile_px, "CLAHE tile size, px; range: 8..4096")
      ->capture_default_str();
  c->add_option("--clahe-clip", j.preprocess.clahe_clip, "CLAHE clip limit; range: > 0, finite")
      ->capture_default_str();
  c->add_option("--highpass", j.preprocess.highpass_sigma_px,
                "High-pass: subtract a Gaussian blur of this sigma, px (0: off); range: 0..256")
      ->capture_default_str();
  // Frames
  c->add_option("--fps", j.fps,
                "Frame rate of an image sequence, Hz; with a video: time its frames index / fps instead of by the "
                "container's time stamps; range: > 0, finite")
      ->capture_default_str();
  c->add_option("--grey", s->grey, "Colour to grey: luma, mean, red, green or blue")
      ->capture_default_str();
  c->add_option("--first", j.first_frame, "First frame used; range: >= 0")->capture_default_str();
  c->add_option("--last", j.last_frame,
                "Last frame used (-1: to the end); range: < 0 (to the end) or >= FIRST + SPACING")
      ->capture_default_str();
  c->add_option("--spacing", j.pair_spacing, "Pair spacing k: pairs (i, i+k); range: 1..1000")
      ->capture_default_str();
  c->add_option("--stride", j.stride, "Step between pair starts; range: >= 1")
      ->capture_default_str();
  c->add_option("--duplicate-tolerance", j.duplicate_tolerance,
                "Frames differing by at most this (grey levels) are repeats; range: >= 0")
      ->capture_default_str();
  c->add_option("--threads", j.threads,
                "Threads, 0 = all cores (a stream runs one pair per thread; the fields are the same for "
                "any count); range: 0..1024")
      ->capture_default_str();
  // Masks
  c->add_option("--centre", s->centre, "Cup centre X,Y in px; range: any finite numbers")
      ->expected(2)
      ->delimiter(',');
  c->add_option("--annulus", s->annulus,
                "Measure only R_INNER <= r <= R_OUTER (px); range: 0 <= R_INNER < R_OUTER, "
                "finite, or 0,0 (off)")
      ->expected(2)
      ->delimiter(',');
  c->add_option("--mask-image", j.mask_image, "Static mask image (non-zero = masked)");
  c->add_option("--mask-fraction", p.mask_fraction,
                "Window masked above this fraction of masked pixels; range: 0..1")
      ->capture_default_str();
  c->add_option("--vane", s->vane,
                "Rotating vane mask: BLADES,HALF_WIDTH_PX,RADIUS_PX; range: BLADES a whole "
                "number in 1..64, 0 < HALF_WIDTH_PX < RADIUS_PX")
      ->expected(3)
      ->delimiter(',');
  c->add_option("--vane-angle0-deg", j.vane.angle0_deg,
                "Blade 0 direction at phi = 0, deg CCW from +x; range: any finite number")
      ->capture_default_str();
  c->add_option("--vane-margin-px", j.vane.margin_px, "Grow the vane mask by this, px; range: >= 0")
      ->capture_default_str();
  c->add_option("--phi0-rad", j.vane.phi0_rad,
                "Vane amplitude: phi = phi0 sin(2 pi f t + phase); range: -1000..1000")
      ->capture_default_str();
  c->add_option("--f-hz", j.vane.f_Hz,
                "Vane frequency f, Hz; range: 0..1e6")
      ->capture_default_str();
  c->add_option("--phase-rad", j.vane.phase_rad, "Vane phase, rad; range: any finite number")
      ->capture_default_str();
  c->add_option("--angle-log", j.vane.log_path, "Vane angle log CSV with columns time_s,angle_rad");
  c->add_option("--log-offset-s", j.vane.log_offset_s,
                "Log time = frame time + offset, s; range: any finite number")
      ->capture_default_str();
  c->add_flag("--log-offset-auto", j.vane.log_offset_auto,
              "Find the log offset by matching the vane angle seen in the frames");
  c->add_flag("--phase-auto", j.vane.phase_auto,
              "Find the vane phase by fitting phi0 sin(2 pi f t + phase) to the vane angle seen in the frames");
  // Attributes
  c->add_option("--m-per-px", s->m_per_px,
                "Calibration stored in the output, m per px; range: > 0, finite");
  c->add_option("--N", s->n_chain,
                "Chain length N stored in the output; range: a whole number in 1..1e9");
  c->add_option("--attr", s->attrs, "Extra KEY=VALUE attribute (repeatable)");
  return {{c, [c, s, &ctx] { return run_piv(*c, *s, ctx); }}};
}

}  // namespace shearzone::apps
