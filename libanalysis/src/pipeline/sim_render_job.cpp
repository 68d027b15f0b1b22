// `shearzone sim render`: see shearzone/pipeline/sim_render_job.hpp.
#include "shearzone/pipeline/sim_render_job.hpp"

#include <chrono>
#include <cmath>
#include <memory>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/io/angle_log.hpp"
#include "shearzone/io/atomic_output.hpp"
#include "shearzone/io/image.hpp"
#include "shearzone/io/json.hpp"
#include "shearzone/io/video.hpp"

namespace shearzone::pipeline {
namespace {

constexpr double kPi = std::numbers::pi;

std::string num(double v) { return fmt::format("{:.17g}", v); }

}  // namespace

synth::CupGeometry filmed_geometry(const sim::FilmedCup& cup) {
  return {.bead_diameter_m = cup.bead_diameter_m, .centre_x_m = cup.cup_cx_m, .centre_y_m = cup.cup_cy_m,
          .radius_m = cup.cup_radius_m, .height_m = cup.cup_height_m, .vane_blades = cup.vane_blades,
          .vane_radius_m = cup.vane_radius_m, .vane_height_m = cup.vane_height_m};
}

synth::CupBeads filmed_beads(sim::FrameBodies&& bodies) {
  return {std::move(bodies.x), std::move(bodies.y), std::move(bodies.z), std::move(bodies.id),
          std::move(bodies.mobile)};
}

void SimRenderOptions::validate() const {
  if (format != "mp4" && format != "png")
    throw ConfigError(fmt::format("--format \"{}\": expected mp4 or png", format));
  if (codec != "mp4v" && codec != "avc1") throw ConfigError(fmt::format("--codec \"{}\": expected mp4v or avc1", codec));
  if (projection != "pinhole" && projection != "orthographic")
    throw ConfigError(fmt::format("--projection \"{}\": expected pinhole or orthographic", projection));
  if (!(width_px >= 16 && width_px <= 16384 && height_px >= 16 && height_px <= 16384))
    throw ConfigError(fmt::format("--size {}x{}: expected 16..16384 px each way", width_px, height_px));
  if (format == "mp4" && (width_px % 2 != 0 || height_px % 2 != 0))
    throw ConfigError(fmt::format("--size {}x{}: an MP4 needs even sizes", width_px, height_px));
  // A frame piv can read back (and a render that ends in reasonable time and memory).
  if (static_cast<double>(width_px) * height_px > io::kMaxImagePixels)
    throw ConfigError(fmt::format("--size {}x{}: {:.3g} pixels per frame; expected at most {:.0e} (the largest frame "
                                  "piv reads)",
                                  width_px, height_px, static_cast<double>(width_px) * height_px,
                                  io::kMaxImagePixels));
  // MPEG-4 part 2 (FFmpeg's mpeg4 encoder) holds at most 8190 px each way.
  if (format == "mp4" && codec == "mp4v" && (width_px > 8190 || height_px > 8190))
    throw ConfigError(fmt::format("--size {}x{}: --codec mp4v holds at most 8190 px each way (expected --codec avc1 "
                                  "or a smaller size)",
                                  width_px, height_px));
  if (core::is_set(m_per_px) && !(m_per_px > 0 && std::isfinite(m_per_px)))
    throw ConfigError(fmt::format("--m-per-px {}: expected a finite scale > 0", m_per_px));
  if (!(height_m > 0 && std::isfinite(height_m)))
    throw ConfigError(fmt::format("--height-m {}: expected a finite height > 0", height_m));
  if (first_frame < 0 || (last_frame >= 0 && last_frame < first_frame + 1))
    throw ConfigError(fmt::format("--first {} --last {}: expected 0 <= first < last (or last -1: to the end)",
                                  first_frame, last_frame));
  look.validate();
}

PivJobOptions camera_piv_options(const sim::FilmedCup& cup, const synth::CupImage& image, double m_per_px,
                                 double vane_phase_video_rad, PivJobOptions base) {
  PivJobOptions p = std::move(base);
  p.fps = cup.fps;
  p.centre_x_px = image.centre_x_px;
  p.centre_y_px = image.centre_y_px;
  // The profile's first bin edge: the vane's radius on the bead surface.
  p.annulus_inner_px = image.vane_surface_radius_px;
  p.annulus_outer_px = image.cup_radius_px;
  const bool drive = cup.vane_blades > 0 && cup.f_Hz > 0;
  if (cup.vane_blades > 0) {
    p.vane.geometry = {cup.vane_blades, image.vane_half_width_px, image.vane_radius_px};
    p.vane.margin_px = 2.0;
    if (drive) {
      p.vane.phi0_rad = cup.phi0_rad;
      p.vane.f_Hz = cup.f_Hz;
      p.vane.phase_rad = vane_phase_video_rad;
    }
  }
  p.attributes = {{"m_per_px", num(m_per_px)}, {"N", num(cup.N)}};
  if (drive) {
    p.attributes.emplace_back("f_Hz", num(cup.f_Hz));
    p.attributes.emplace_back("phi0_rad", num(cup.phi0_rad));
  }
  p.attributes.emplace_back("cup_radius_px", num(image.cup_radius_px));
  p.attributes.emplace_back("vane_radius_px", num(image.vane_surface_radius_px));
  p.attributes.emplace_back("bead_diameter_m", num(cup.bead_diameter_m));
  return p;
}

std::string camera_piv_toml(const PivJobOptions& p) {
  std::string t = "# `shearzone piv VIDEO --config piv.toml -o fields.h5`: written by `shearzone sim render` for "
                  "this video\n";
  t += fmt::format("fps = {}\n", num(p.fps));
  t += fmt::format("centre = [{}, {}]\n", num(p.centre_x_px), num(p.centre_y_px));
  t += fmt::format("annulus = [{}, {}]\n", num(p.annulus_inner_px), num(p.annulus_outer_px));
  const auto& v = p.vane;
  if (v.geometry.blades > 0) {
    t += fmt::format("vane = [{}, {}, {}]\nvane-margin-px = {}\n", v.geometry.blades, num(v.geometry.half_width_px),
                     num(v.geometry.radius_px), num(v.margin_px));
    if (v.f_Hz > 0)
      t += fmt::format("phi0-rad = {}\nf-hz = {}\nphase-rad = {}\n", num(v.phi0_rad), num(v.f_Hz), num(v.phase_rad));
  }
  // m_per_px and N have options of their own; f_Hz and phi0_rad come with --f-hz and
  // --phi0-rad; the rest are --attr pairs.
  std::string attrs;
  for (const auto& [k, value] : p.attributes) {
    if (k == "m_per_px") t += fmt::format("m-per-px = {}\n", value);
    else if (k == "N") t += fmt::format("N = {}\n", value);
    else if (k != "f_Hz" && k != "phi0_rad") attrs += fmt::format("{}\"{}={}\"", attrs.empty() ? "" : ", ", k, value);
  }
  if (!attrs.empty()) t += "attr = [" + attrs + "]\n";
  return t;
}

SimRenderSummary run_sim_render(const SimRenderOptions& o, const core::Metadata& header,
                                const core::ProgressCallback& progress) {
  o.validate();
  const auto t0 = std::chrono::steady_clock::now();
  const sim::FramesFile frames(o.run_dir / "frames.h5");
  const sim::FilmedCup& cup = frames.cup();
  const std::int64_t last =
      o.last_frame < 0 ? static_cast<std::int64_t>(frames.size()) - 1 : o.last_frame;
  if (last >= static_cast<std::int64_t>(frames.size()) || o.first_frame >= last)
    throw ConfigError(fmt::format("--first {} --last {}: {} holds frames 0..{} (a video needs two)", o.first_frame,
                                  o.last_frame, frames.path(), frames.size() - 1));
  SimRenderSummary sum;
  sum.surface_z_m = frames.surface_z_m();
  const synth::CupGeometry geometry = filmed_geometry(cup);
  sum.camera = synth::cup_camera(geometry, sum.surface_z_m, o.projection == "orthographic", o.width_px, o.height_px, o.m_per_px,
                          o.height_m);
  const synth::DownCamera& cam = sum.camera;
  sum.image = synth::cup_image(cam, geometry, sum.surface_z_m);
  const synth::CupImage& im = sum.image;
  const double t_first = frames.time(static_cast<std::size_t>(o.first_frame));
  // The drive in video time (t = 0 at the first frame drawn).
  const double phase_video = cup.vane_phase_rad + 2.0 * kPi * cup.f_Hz * t_first;

  io::AtomicOutputSet out(o.output_dir, o.force);
  const std::size_t count = static_cast<std::size_t>(last - o.first_frame + 1);
  std::vector<std::string> names;
  if (o.format == "mp4") {
    names.push_back("video.mp4");
  } else {
    for (std::size_t k = 0; k < count; ++k) names.push_back(fmt::format("frame_{:06d}.png", k));
  }
  for (const auto& n : names) out.check(n);
  for (const char* n : {"camera.json", "piv.toml", "vane_angle.csv"}) out.check(n);

  std::unique_ptr<io::VideoWriter> writer;
  if (o.format == "mp4") {
    auto& f = out.add(names[0]);
    writer = std::make_unique<io::VideoWriter>(f.temp_path(), cup.fps, cv::Size(o.width_px, o.height_px), o.codec,
                                               f.final_path());
  }
  core::Metadata meta = header;
  meta.emplace_back("run", o.run_dir.string());
  meta.emplace_back("time_s", "video time: 0 at the first frame drawn (simulated time " + num(t_first) + " s)");
  meta.emplace_back("angle_rad", "vane deflection phi, > 0 counter-clockwise seen from above (and on the image)");
  io::AngleLog angles;
  for (std::size_t k = 0; k < count; ++k) {
    const std::size_t fk = static_cast<std::size_t>(o.first_frame) + k;
    sim::FrameBodies bodies = frames.frame(fk);
    const double t_s = bodies.t_s, phi = cup.vane_angle(t_s);
    const synth::ProjectedBeads beads =
        synth::project_beads(cam, geometry, filmed_beads(std::move(bodies)), sum.surface_z_m, o.look);
    const cv::Mat img = synth::render_cup_frame(cam, geometry, sum.surface_z_m, beads, phi, o.look, fk);
    if (writer) {
      writer->write(img);
    } else {
      const std::string bytes = io::encode_image(img, o.output_dir / names[k]);
      out.add(names[k]).stream().write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    }
    angles.time_s.push_back(t_s - t_first);
    angles.angle_rad.push_back(phi);
    if (progress) progress(k + 1, count);
  }
  if (writer) writer->close();
  io::write_angle_log(out.add("vane_angle.csv").stream(), meta, angles);

  // camera.json: everything in px that the lab pipeline needs, and how it was drawn.
  {
    std::string j = "{\n";
    auto add = [&j](const std::string& k, const std::string& v) { j += "  \"" + k + "\": " + v + ",\n"; };
    auto str = [](const std::string& s) { return io::json_string(s); };  // escaped: any folder name
    // every digit of a double; a value JSON cannot hold (NaN) as null
    auto jnum = [](double v) { return std::isfinite(v) ? fmt::format("{:.17g}", v) : std::string("null"); };
    add("source", str("shearzone sim render"));
    add("run", str(o.run_dir.generic_string()));
    add("video", str(o.format == "mp4" ? "video.mp4" : "frame_%06d.png"));
    add("frames", std::to_string(count));
    add("fps", jnum(cup.fps));
    add("t0_sim_s", jnum(t_first));
    add("projection", str(cam.projection_name()));
    add("width_px", std::to_string(cam.width_px));
    add("height_px", std::to_string(cam.height_px));
    add("m_per_px", jnum(cam.m_per_px));
    add("m_per_px_plane_z_m", jnum(sum.surface_z_m));
    if (!cam.orthographic) {
      add("pinhole_height_m", jnum(cam.height_m));
      add("focal_px", jnum(cam.focal_px()));
    }
    add("centre_x_px", jnum(im.centre_x_px));
    add("centre_y_px", jnum(im.centre_y_px));
    add("cup_radius_px", jnum(im.cup_radius_px));
    add("rim_radius_px", jnum(im.rim_radius_px));
    add("rim_line_radius_px", jnum(im.rim_radius_px + 0.5 * o.look.rim_width_px));
    add("vane_radius_px", jnum(im.vane_surface_radius_px));
    add("vane_drawn_radius_px", jnum(im.vane_radius_px));
    add("vane_blades", std::to_string(cup.vane_blades));
    add("vane_half_width_px", jnum(im.vane_half_width_px));
    add("bead_diameter_m", jnum(cup.bead_diameter_m));
    add("bead_diameter_px", jnum(cup.bead_diameter_m * cam.px_per_m(sum.surface_z_m)));
    add("cup_radius_m", jnum(cup.cup_radius_m));
    add("N", std::to_string(cup.N));
    add("f_Hz", jnum(cup.f_Hz));
    add("phi0_rad", jnum(cup.phi0_rad));
    add("vane_phase_rad", jnum(phase_video));
    add("angle_log", str("vane_angle.csv"));
    add("noise", jnum(o.look.noise));
    add("blur_px", jnum(o.look.blur_px));
    add("jpeg_quality", std::to_string(o.look.jpeg_quality));
    add("seed", std::to_string(o.look.seed));
    j += "  \"conventions\": \"pixel centres at integers; x right along world +X, y down along world -Y (seen from "
         "above); vane angle phi(t) = phi0_rad sin(2 pi f_Hz t + vane_phase_rad), t video time (0 at frame 0), "
         "blade j at phi + 2 pi j / vane_blades counter-clockwise from +x; m_per_px holds on the plane "
         "z = m_per_px_plane_z_m (the bead surface: the 90th percentile of the bead centres' heights)\"\n}\n";
    out.add("camera.json").stream() << j;
  }
  // piv.toml: the options of `shearzone piv` that this camera fixes.
  out.add("piv.toml").stream() << camera_piv_toml(camera_piv_options(cup, im, cam.m_per_px, phase_video));
  out.commit_all();
  for (const auto& n : names) sum.files.push_back(o.output_dir / n);
  for (const char* n : {"camera.json", "piv.toml", "vane_angle.csv"}) sum.files.push_back(o.output_dir / n);
  sum.frames = count;
  sum.bead_diameter_px = cup.bead_diameter_m * cam.px_per_m(sum.surface_z_m);
  sum.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return sum;
}

}  // namespace shearzone::pipeline
