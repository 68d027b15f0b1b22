// `shearzone sim check`: see shearzone/pipeline/sim_check_job.hpp.
#include "shearzone/pipeline/sim_check_job.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/core/unset.hpp"
#include "shearzone/io/atomic_output.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/io/field_file.hpp"
#include "shearzone/io/hdf5.hpp"
#include "shearzone/io/profile_csv.hpp"
#include "shearzone/io/video.hpp"
#include "shearzone/pipeline/profile_job.hpp"
#include "shearzone/pipeline/width_job.hpp"
#include "shearzone/piv/options.hpp"
#include "shearzone/piv/texture.hpp"
#include "shearzone/track/track.hpp"

namespace shearzone::pipeline {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

/// The branches of a run: the run itself when it holds frames.h5, else its sub-folders
/// that do (a protocol run: phi0_*), in name order.
std::vector<std::pair<std::string, fs::path>> branches_of(const fs::path& run) {
  std::vector<std::pair<std::string, fs::path>> out;
  if (!fs::is_directory(run)) throw InputError(fmt::format("{}: not a run folder", run.string()));
  if (fs::exists(run / "frames.h5")) {
    out.emplace_back(run.filename().empty() ? run.parent_path().filename().string() : run.filename().string(), run);
    return out;
  }
  for (const auto& e : fs::directory_iterator(run))
    if (e.is_directory() && fs::exists(e.path() / "frames.h5")) out.emplace_back(e.path().filename().string(), e.path());
  std::sort(out.begin(), out.end());
  if (out.empty())
    throw InputError(fmt::format("{}: no frames.h5 in it or its branch folders: run a scene with a [camera] (its "
                                 "frames key true)",
                                 run.string()));
  return out;
}

constexpr std::size_t kStaticFrames = 10;                  // the noise reference clip
constexpr std::uint64_t kStaticSeedOffset = 1000000000ull;  // its noise streams, apart from the video's

/// A width row for a stage that gave no profile.
WidthRow no_result(const std::string& why) {
  WidthRow r;
  r.label = "no_result";
  r.advice = why;
  r.status = profile::WidthStatus::kNoiseLimited;
  r.rc_m = r.ci_low_m = r.ci_high_m = core::kUnset;
  return r;
}

/// RMS of v_abs(a) - v_abs(b) over b's bins inside a's range (a linearly interpolated).
double profile_rms_diff(const fs::path& a_path, const fs::path& b_path) {
  const io::ProfileCsv a = io::read_profile_csv(a_path), b = io::read_profile_csv(b_path);
  double s = 0;
  std::size_t n = 0;
  for (const auto& rb : b.rows) {
    if (!std::isfinite(rb.v_abs)) continue;
    for (std::size_t k = 0; k + 1 < a.rows.size(); ++k) {
      const auto &p = a.rows[k], &q = a.rows[k + 1];
      if (!(rb.r_m >= p.r_m - 1e-9 && rb.r_m <= q.r_m + 1e-9) || !std::isfinite(p.v_abs) || !std::isfinite(q.v_abs))
        continue;
      const double w = q.r_m > p.r_m ? std::clamp((rb.r_m - p.r_m) / (q.r_m - p.r_m), 0.0, 1.0) : 0.0;
      const double d = (1 - w) * p.v_abs + w * q.v_abs - rb.v_abs;
      s += d * d;
      ++n;
      break;
    }
  }
  return n > 0 ? std::sqrt(s / static_cast<double>(n)) : core::kUnset;
}

}  // namespace

std::string SimCheckSetting::label() const {
  if (method == PairMethod::kTrack) return "track_k" + std::to_string(spacing);
  std::string s = "w";
  for (std::size_t k = 0; k < windows_px.size(); ++k) s += (k ? "-" : "") + std::to_string(windows_px[k]);
  if (!interpolation.empty()) s += "_" + interpolation;
  return s + "_k" + std::to_string(spacing);
}

void SimCheckOptions::validate() const {
  render.validate();
  width.validate();
  if (!(truth_spacing_px >= 1 && truth_spacing_px <= 1024))
    throw ConfigError(fmt::format("--truth-spacing-px {}: expected 1..1024 px", truth_spacing_px));
  for (const auto& s : settings) {
    if (!(s.spacing >= 1 && s.spacing <= 1000))
      throw ConfigError(fmt::format("--spacings {}: expected 1..1000", s.spacing));
    if (s.method == PairMethod::kTrack) continue;
    if (s.windows_px.empty()) throw ConfigError("a PIV setting needs window sizes");
    piv::PivOptions p = piv.piv;  // the PIV's own checks, before hours of rendering
    p.windows_px = s.windows_px;
    if (!s.interpolation.empty()) p.interpolation = piv::interpolation_from_name(s.interpolation);
    p.validate();
  }
}

namespace {

/// Every branch's inputs before any work (a missing surface.h5 used to be found after
/// the first branch's video and truths were written), and the two files of a branch
/// from one run: the camera's frames and the simulator's surface field set against each
/// other must describe the same motion.
void check_branch_inputs(const std::vector<std::pair<std::string, fs::path>>& branches) {
  for (const auto& [name, dir] : branches)
    for (const char* need : {"frames.h5", "surface.h5"})
      if (!fs::is_regular_file(dir / need))
        throw InputError(fmt::format("{}: no such file; expected the branch's {} (a scene with a [camera] writes "
                                     "frames.h5 and surface.h5)",
                                     (dir / need).string(), need));
  for (const auto& [name, dir] : branches) {
    auto run_id = [](const fs::path& p) {
      const io::H5File f = io::H5File::open_read(p);
      return f.has_attribute("/", "run_id") ? f.attribute_string("/", "run_id") : std::string("none");
    };
    const std::string a = run_id(dir / "frames.h5"), b = run_id(dir / "surface.h5");
    for (const auto& [file, id] : {std::pair{"frames.h5", a}, std::pair{"surface.h5", b}})
      if (id == "none")
        throw InputError(fmt::format("{}: no run_id attribute (written by an older shearzone): run the scene again",
                                     (dir / file).string()));
    if (a != b)
      throw InputError(fmt::format("{}: run_id {} is not frames.h5's run_id {}: the two files come from different "
                                   "runs (expected the frames.h5 and surface.h5 of one run of shearzone sim)",
                                   (dir / "surface.h5").string(), b, a));
  }
}

/// A field through `profile` and `width` with the check's options (no_result where no
/// profile comes out); the seconds each took, where asked.
WidthRow profile_and_width(const SimCheckOptions& o, const core::Metadata& header, double d, const fs::path& field,
                           const fs::path& prof, const fs::path& wid, double* prof_s, double* wid_s,
                           const fs::path& noise_ref = {}) {
  auto t1 = Clock::now();
  ProfileJobOptions po;
  po.input = field;
  po.noise_ref = noise_ref;
  po.output = prof;
  po.force = o.force;
  po.bead_diameter_m = d;
  try {
    run_profile_job(po, header);
  } catch (const NoResultError& e) {
    return no_result(e.what());
  }
  if (prof_s) *prof_s = since(t1);
  t1 = Clock::now();
  WidthJobOptions wo;
  wo.inputs = {prof};
  wo.output = wid;
  wo.force = o.force;
  wo.width = o.width;
  const auto r = run_width_job(wo, header);
  if (wid_s) *wid_s = since(t1);
  return r.front();
}

/// A branch filmed, and what the camera and the simulator saw: the video, the beads as
/// projected in every frame with the vane's angle, the static clip for the noise floor
/// and both truths' widths.
struct FilmedBranch {
  SimRenderOptions render;
  SimRenderSummary rs;
  sim::FilmedCup cup;
  synth::CupGeometry geometry;  ///< the cup as the renderer draws it
  double phase_video = 0.0;  ///< the drive's phase in video time
  fs::path video, static_clip;
  std::vector<synth::ProjectedBeads> proj;
  std::vector<double> vane_angles;
  WidthRow centres, surface;
  double render_s = 0.0, truth_s = 0.0;
};

/// A truth's field file: one field per frame pair (k, k + 1) from `field_of(k)`, and the
/// root attributes `profile` reads (the geometry and the drive).
void write_truth(const SimCheckOptions& o, const FilmedBranch& fb, const fs::path& path, const char* source,
                 const std::function<core::VectorField(std::size_t)>& field_of) {
  const synth::CupImage& im = fb.rs.image;
  const sim::FilmedCup& cup = fb.cup;
  io::AtomicOutput f(path, o.force);
  {
    io::FieldFileWriter w(f.temp_path());
    for (std::size_t k = 0; k + 1 < fb.rs.frames; ++k)
      w.append(field_of(k), static_cast<std::int64_t>(k), static_cast<std::int64_t>(k + 1), k / cup.fps,
               1.0 / cup.fps);
    w.set_attribute("centre_x_px", im.centre_x_px);
    w.set_attribute("centre_y_px", im.centre_y_px);
    w.set_attribute("cup_radius_px", im.cup_radius_px);
    w.set_attribute("vane_radius_px", im.vane_surface_radius_px);
    w.set_attribute("m_per_px", fb.rs.camera.m_per_px);
    w.set_attribute("N", static_cast<double>(cup.N));
    if (cup.f_Hz > 0) {
      w.set_attribute("f_Hz", cup.f_Hz);
      w.set_attribute("phi0_rad", cup.phi0_rad);
      w.set_attribute("vane_phase_rad", fb.phase_video);
    }
    w.set_attribute("fps", cup.fps);
    w.set_attribute("noise_sigma_px", 0.0);
    w.set_attribute("source", source);
    w.close();
  }
  f.commit();
}

/// The camera's truth per node of a grid of `truth_spacing_px` (synth::visible_motion).
void write_centres_truth(const SimCheckOptions& o, const FilmedBranch& fb, const fs::path& path) {
  std::vector<double> gx, gy;
  for (double x = 0.5 * o.truth_spacing_px - 0.5; x < fb.rs.camera.width_px - 0.5; x += o.truth_spacing_px)
    gx.push_back(x);
  for (double y = 0.5 * o.truth_spacing_px - 0.5; y < fb.rs.camera.height_px - 0.5; y += o.truth_spacing_px)
    gy.push_back(y);
  write_truth(o, fb, path, "shearzone sim check: the camera's truth (surface beads' centre motion)",
              [&](std::size_t k) {
                return synth::visible_motion(fb.proj[k], fb.proj[k + 1], gx, gy, fb.rs.image, fb.cup.vane_blades,
                                             fb.vane_angles[k]);
              });
}

/// The camera's truth bead by bead (synth::visible_beads: each visible bead's centre
/// motion, counted once, at its centre) on the tracker's grid of `cell_px` cells: the
/// reference of a tracking setting, binned as the tracker bins.
void write_beads_truth(const SimCheckOptions& o, const FilmedBranch& fb, int cell_px, const fs::path& path) {
  const cv::Size size(fb.rs.camera.width_px, fb.rs.camera.height_px);
  write_truth(o, fb, path, "shearzone sim check: the camera's truth bead by bead (visible beads' centre motion)",
              [&](std::size_t k) {
                synth::VisibleBeads v = synth::visible_beads(fb.proj[k], fb.proj[k + 1], fb.rs.image,
                                                             fb.cup.vane_blades, fb.vane_angles[k]);
                const std::size_t n = v.x_px.size();
                track::PairBeads beads{std::move(v.x_px), std::move(v.y_px), std::move(v.u_px), std::move(v.v_px),
                                       std::vector<double>(n, 0.0), std::vector<std::uint8_t>(n, 1)};
                return track::beads_to_grid(beads, size, cell_px, cv::Mat());
              });
}

/// The PIV's noise floor, as in the lab: a static clip (frame 0's packing and vane,
/// fresh sensor noise per frame) through the same PIV setting is `profile`'s
/// --noise-ref. (The default floor, the motion in the outer 15 % of the annulus, is
/// motion here: the zone of a small cup reaches its wall.)
void write_static_clip(const SimCheckOptions& o, const FilmedBranch& fb) {
  io::AtomicOutput f(fb.static_clip, o.force);
  {
    io::VideoWriter w(f.temp_path(), fb.cup.fps, cv::Size(fb.rs.camera.width_px, fb.rs.camera.height_px),
                      fb.render.codec, f.final_path());
    for (std::size_t k = 0; k < kStaticFrames; ++k)
      w.write(synth::render_cup_frame(fb.rs.camera, fb.geometry, fb.rs.surface_z_m, fb.proj[0], fb.vane_angles[0],
                                      fb.render.look, kStaticSeedOffset + k));
    w.close();
  }
  f.commit();
}

/// 1. and 2.: the branch filmed, and the truths: the camera's (bead centres) and the
/// simulator's surface field, each through profile and width.
FilmedBranch film_branch(const SimCheckOptions& o, const core::Metadata& header, const std::string& name,
                         const fs::path& dir, const std::function<void(const std::string&)>& say) {
  const fs::path bout = o.output_dir / name;
  FilmedBranch fb;
  auto t = Clock::now();
  fb.render = o.render;
  fb.render.run_dir = dir;
  fb.render.output_dir = bout / "video";
  fb.render.force = o.force;
  say(fmt::format("{}: render", name));
  fb.rs = run_sim_render(fb.render, header);
  fb.render_s = since(t);
  const sim::FramesFile frames(dir / "frames.h5");
  fb.cup = frames.cup();
  const sim::FilmedCup& cup = fb.cup;
  fb.phase_video =
      cup.vane_phase_rad + 2.0 * std::numbers::pi * cup.f_Hz * frames.time(0 + fb.render.first_frame);
  fb.video = fb.rs.files.front();
  fb.static_clip = bout / "static.mp4";

  t = Clock::now();
  say(fmt::format("{}: truth", name));
  fb.geometry = filmed_geometry(cup);
  for (std::size_t k = 0; k < fb.rs.frames; ++k) {
    sim::FrameBodies b = frames.frame(static_cast<std::size_t>(fb.render.first_frame) + k);
    fb.vane_angles.push_back(cup.vane_angle(b.t_s));
    fb.proj.push_back(
        synth::project_beads(fb.rs.camera, fb.geometry, filmed_beads(std::move(b)), fb.rs.surface_z_m, fb.render.look));
  }
  write_centres_truth(o, fb, bout / "truth_centres.h5");
  const double d = cup.bead_diameter_m;
  fb.centres = profile_and_width(o, header, d, bout / "truth_centres.h5", bout / "truth_centres_profile.csv",
                                 bout / "truth_centres_width.csv", nullptr, nullptr);
  fb.surface = profile_and_width(o, header, d, dir / "surface.h5", bout / "truth_surface_profile.csv",
                                 bout / "truth_surface_width.csv", nullptr, nullptr);
  write_static_clip(o, fb);
  fb.truth_s = since(t);
  return fb;
}

/// The PIV error per vector against the camera's truth at the same node and pair: RMS
/// and mean of each component over valid and replaced vectors where the truth sees a bead.
void piv_error(const fs::path& fields, const FilmedBranch& fb, SimCheckRow& row) {
  const auto reader = io::open_field_file(fields, core::kUnset);
  double se = 0, su = 0, sv = 0;
  std::size_t n = 0;
  for (std::size_t k = 0; k < reader->size(); ++k) {
    core::VectorField f;
    double ta = 0, dt = 0;
    reader->read(k, f, ta, dt);
    const auto a = static_cast<std::size_t>(std::llround(ta * fb.cup.fps));
    const auto b = static_cast<std::size_t>(std::llround((ta + dt) * fb.cup.fps));
    if (b >= fb.proj.size()) continue;
    const core::VectorField tr = synth::visible_motion(fb.proj[a], fb.proj[b], f.x_px, f.y_px, fb.rs.image,
                                                       fb.cup.vane_blades, fb.vane_angles[a]);
    for (std::size_t q = 0; q < f.size(); ++q) {
      if ((f.flag[q] != core::VectorFlag::kValid && f.flag[q] != core::VectorFlag::kReplaced) ||
          tr.flag[q] != core::VectorFlag::kValid)
        continue;
      const double du = f.u_px[q] - tr.u_px[q], dv = f.v_px[q] - tr.v_px[q];
      se += du * du + dv * dv;
      su += du;
      sv += dv;
      ++n;
    }
  }
  row.compared_vectors = n;
  row.piv_rms_error_px = n > 0 ? std::sqrt(se / static_cast<double>(n)) : core::kUnset;
  row.piv_bias_u_px = n > 0 ? su / static_cast<double>(n) : core::kUnset;
  row.piv_bias_v_px = n > 0 ? sv / static_cast<double>(n) : core::kUnset;
}

/// 3. The lab pipeline on the video with one PIV setting: piv (and piv of the static
/// clip, the noise floor), profile, width, and the comparison with both truths.
SimCheckRow run_setting(const SimCheckOptions& o, const core::Metadata& header, const std::string& name,
                        const FilmedBranch& fb, const SimCheckSetting& st,
                        const std::function<void(const std::string&)>& say) {
  const sim::FilmedCup& cup = fb.cup;
  const fs::path bout = o.output_dir / name;
  SimCheckRow row;
  row.branch = name;
  row.setting = st.label();
  row.phi0_rad = cup.phi0_rad;
  row.N = cup.N;
  row.bead_diameter_m = cup.bead_diameter_m;
  row.bead_diameter_px = fb.rs.bead_diameter_px;
  row.render_s = fb.render_s;
  row.truth_s = fb.truth_s;
  row.centres = fb.centres;
  row.surface = fb.surface;
  const fs::path sout = bout / st.label();
  PivJobOptions p = camera_piv_options(cup, fb.rs.image, fb.rs.camera.m_per_px, fb.phase_video, o.piv);
  p.inputs = {fb.video.string()};
  p.output = sout / "fields.h5";
  p.force = o.force;
  p.method = st.method;
  if (st.method == PairMethod::kPiv) p.piv.windows_px = st.windows_px;
  if (!st.interpolation.empty()) p.piv.interpolation = piv::interpolation_from_name(st.interpolation);
  p.pair_spacing = st.spacing;
  p.validate();
  say(fmt::format("{}: piv {}", name, st.label()));
  auto t = Clock::now();
  PivJobSummary ps;
  try {
    ps = run_piv_job(p, header);
  } catch (const InputError& e) {
    // A setting the video cannot take (windows larger than the unmasked cup): a row
    // that says so, not the end of the grid.
    row.piv_s = since(t);
    row.video = no_result(e.what());
    row.profile_rms_diff_m_per_s = row.profile_rms_diff_surface_m_per_s = core::kUnset;
    row.piv_rms_error_px = row.piv_bias_u_px = row.piv_bias_v_px = core::kUnset;
    row.invalid_fraction = core::kUnset;
    return row;
  }
  row.piv_s = since(t);
  row.pairs = ps.pairs;
  if (st.method == PairMethod::kPiv && ps.windows_px != st.windows_px) {  // sized to the texture: say which were used
    SimCheckSetting used = st;
    used.windows_px = ps.windows_px;
    row.setting = used.label();
  }
  if (st.method == PairMethod::kTrack) {
    // The tracker's reference: the camera's truth bead by bead, on its grid.
    say(fmt::format("{}: truth bead by bead for {}", name, st.label()));
    write_beads_truth(o, fb, ps.track_cell_px, sout / "truth_beads.h5");
    row.centres = profile_and_width(o, header, cup.bead_diameter_m, sout / "truth_beads.h5",
                                    sout / "truth_beads_profile.csv", sout / "truth_beads_width.csv", nullptr, nullptr);
  }
  const std::size_t not_masked = ps.pairs * ps.vectors_per_pair - ps.masked;
  row.invalid_fraction = not_masked > 0 ? static_cast<double>(ps.invalid) / static_cast<double>(not_masked) : 0;
  say(fmt::format("{}: profile {}", name, st.label()));
  // The same setting on the static clip: the noise floor (vane at rest: no vane mask).
  PivJobOptions ps0 = p;
  ps0.inputs = {fb.static_clip.string()};
  ps0.output = sout / "static_fields.h5";
  ps0.vane.f_Hz = 0.0;
  ps0.vane.phi0_rad = 0.0;
  ps0.vane.phase_rad = 0.0;
  ps0.vane.angle0_deg = fb.vane_angles[0] * 180.0 / std::numbers::pi;
  (void)run_piv_job(ps0, header);
  row.video = profile_and_width(o, header, cup.bead_diameter_m, p.output, sout / "profile.csv", sout / "width.csv",
                                &row.profile_s, &row.width_s, ps0.output);
  if (fs::exists(sout / "profile.csv")) {
    row.profile_rms_diff_m_per_s =
        profile_rms_diff(sout / "profile.csv", st.method == PairMethod::kTrack ? sout / "truth_beads_profile.csv"
                                                                                : bout / "truth_centres_profile.csv");
    row.profile_rms_diff_surface_m_per_s = profile_rms_diff(sout / "profile.csv", bout / "truth_surface_profile.csv");
  } else {
    row.profile_rms_diff_m_per_s = row.profile_rms_diff_surface_m_per_s = core::kUnset;
  }
  piv_error(p.output, fb, row);
  return row;
}

/// closed_loop.csv: a row per branch and setting.
void write_closed_loop(const SimCheckOptions& o, const core::Metadata& header, const std::vector<SimCheckRow>& rows) {
  core::Metadata meta = header;
  meta.emplace_back("run", o.run_dir.string());
  meta.emplace_back("v_c_m_per_s", io::format_number(o.width.v_c_m_per_s));
  // The PIV settings every row shares (the rows differ in windows, interpolation, spacing).
  for (const auto& kv : o.piv.piv.to_metadata()) {
    if (kv.first == "piv_predictor_smoothing_steps") meta.push_back(kv);
    if (kv.first == "piv_predictor_smoothing_fit")
      meta.emplace_back(kv.first, o.piv.fit_predictor_to_texture
                                      ? fmt::format("auto: quadratic where the first frame's texture reads as beads "
                                                    "of {} px or more (rendered beads of 8 px or more do), else gaussian; each "
                                                    "setting's fields.h5 names the one used",
                                                    io::format_number(piv::kSmallBeadMinPx))
                                      : kv.second);
  }
  meta.emplace_back("rc_video", "r_c of piv -> profile -> width on the rendered video (geometry from the camera)");
  meta.emplace_back("rc_centres", "r_c of the camera's truth: the surface beads' centre motion on the same camera "
                                  "(what PIV of shiny spheres can at best see); for track_k settings, the same "
                                  "truth bead by bead, each visible bead once at its centre, on the tracker's grid");
  meta.emplace_back("rc_surface", "r_c of the simulator's surface field (surface.h5: material points, spin "
                                  "included)");
  meta.emplace_back("rc_error_over_d", "(rc_video - rc_surface) / d; rc_error_centres_over_d: (rc_video - "
                                       "rc_centres) / d; empty when either is not reported");
  meta.emplace_back("profile_rms_diff_m_per_s", "RMS over the truth's bins of v_abs(video) - v_abs(truth), the "
                                                "video's profile interpolated linearly in r");
  meta.emplace_back("piv_rms_error_px", "RMS of |d_piv - d_camera_truth| over valid and replaced PIV vectors where "
                                        "the truth sees a bead, px per pair; bias: mean of each component");
  meta.emplace_back("invalid_fraction", "invalid vectors over the vectors not masked");
  meta.emplace_back("wall_s", "render_s: the video; truth_s: both truths' fields, profiles and widths; piv_s, "
                              "profile_s, width_s: the lab pipeline on this setting");
  io::AtomicOutput out(o.output_dir / "closed_loop.csv", o.force);
  {
    io::CsvWriter w(out.stream(), meta,
                    {"branch", "phi0_rad", "N", "setting", "pairs", "rc_video_m", "rc_video_ci_low_m",
                     "rc_video_ci_high_m", "rc_video_status", "rc_centres_m", "rc_centres_ci_low_m",
                     "rc_centres_ci_high_m", "rc_centres_status", "rc_surface_m", "rc_surface_ci_low_m",
                     "rc_surface_ci_high_m", "rc_surface_status", "rc_error_over_d", "rc_error_centres_over_d",
                     "profile_rms_diff_m_per_s", "profile_rms_diff_surface_m_per_s", "piv_rms_error_px",
                     "piv_bias_u_px", "piv_bias_v_px", "compared_vectors", "invalid_fraction", "render_s", "truth_s",
                     "piv_s", "profile_s", "width_s"});
    auto f = [](double v) { return io::format_number_or_empty(v); };
    auto st = [](const WidthRow& r) {
      return r.label == "no_result" ? std::string("no_result") : std::string(profile::width_status_name(r.status));
    };
    for (const auto& r : rows) {
      const double e = (r.video.rc_m - r.surface.rc_m) / r.bead_diameter_m;
      const double ec = (r.video.rc_m - r.centres.rc_m) / r.bead_diameter_m;
      w.row(std::vector<std::string>{
          r.branch, f(r.phi0_rad), std::to_string(r.N), r.setting, std::to_string(r.pairs), f(r.video.rc_m),
          f(r.video.ci_low_m), f(r.video.ci_high_m), st(r.video), f(r.centres.rc_m), f(r.centres.ci_low_m),
          f(r.centres.ci_high_m), st(r.centres), f(r.surface.rc_m), f(r.surface.ci_low_m), f(r.surface.ci_high_m),
          st(r.surface), f(e), f(ec), f(r.profile_rms_diff_m_per_s), f(r.profile_rms_diff_surface_m_per_s),
          f(r.piv_rms_error_px), f(r.piv_bias_u_px), f(r.piv_bias_v_px), std::to_string(r.compared_vectors),
          f(r.invalid_fraction), fmt::format("{:.3f}", r.render_s), fmt::format("{:.3f}", r.truth_s),
          fmt::format("{:.3f}", r.piv_s), fmt::format("{:.3f}", r.profile_s), fmt::format("{:.3f}", r.width_s)});
    }
  }
  out.commit();
}

}  // namespace

std::vector<SimCheckRow> run_sim_check(const SimCheckOptions& o, const core::Metadata& header,
                                       const SimCheckProgress& stage) {
  o.validate();
  const auto branches = branches_of(o.run_dir);
  std::vector<SimCheckSetting> settings = o.settings;
  if (settings.empty()) settings.push_back({o.piv.piv.windows_px, 1, ""});
  if (!o.force && fs::exists(o.output_dir / "closed_loop.csv"))
    throw ConfigError(fmt::format("{} exists: give --force to replace it", (o.output_dir / "closed_loop.csv").string()));
  check_branch_inputs(branches);
  // Progress in stages: per branch the render, the truths, then each setting.
  const std::size_t total = branches.size() * (2 + settings.size());
  std::size_t done = 0;
  const std::function<void(const std::string&)> say = [&](const std::string& s) {
    if (stage) stage(s, done, total);
    if (s.find(": profile ") == std::string::npos) ++done;
  };
  std::vector<SimCheckRow> rows;
  for (const auto& [name, dir] : branches) {
    const FilmedBranch fb = film_branch(o, header, name, dir, say);
    for (const SimCheckSetting& st : settings) rows.push_back(run_setting(o, header, name, fb, st, say));
  }
  write_closed_loop(o, header, rows);
  return rows;
}

}  // namespace shearzone::pipeline
