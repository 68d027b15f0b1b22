// `shearzone sim render`: see shearzone/pipeline/sim_render_job.hpp.
#include "shearzone/pipeline/sim_render_job.hpp"

#include <algorithm>
#include <chrono>
#include <map>
#include <cmath>
#include <memory>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "shearzone/core/error.hpp"
#include "shearzone/io/atomic_output.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/io/hdf5.hpp"
#include "shearzone/io/image.hpp"
#include "shearzone/io/json.hpp"
#include "shearzone/io/video.hpp"

namespace shearzone::pipeline {
namespace {

constexpr double kPi = std::numbers::pi;

std::string num(double v) { return fmt::format("{:.17g}", v); }

}  // namespace

void CupLook::validate() const {
  if (!(noise >= 0 && noise <= 1)) throw ConfigError(fmt::format("--noise {}: expected 0..1 of full scale", noise));
  if (!(blur_px >= 0 && blur_px <= 50)) throw ConfigError(fmt::format("--blur-px {}: expected 0..50 px", blur_px));
  if (!(jpeg_quality >= 0 && jpeg_quality <= 100))
    throw ConfigError(fmt::format("--jpeg-quality {}: expected 1..100, or 0 for none", jpeg_quality));
  if (!(depth_fade_d > 0 && albedo_spread >= 0 && albedo_spread < 1))
    throw ConfigError("look: expected depth_fade_d > 0 and 0 <= albedo_spread < 1");
}

ProjectedBeads project_beads(const synth::DownCamera& cam, const sim::FilmedCup& cup, const sim::FrameBodies& bodies,
                             double surface_z_m, const CupLook& look) {
  ProjectedBeads p;
  const double d = cup.bead_diameter_m;
  const double s_ref = cam.px_per_m(surface_z_m);
  for (std::size_t b = 0; b < bodies.x.size(); ++b) {
    // Beads under the rim (the wall's own) are hidden by it.
    if (std::hypot(bodies.x[b] - cup.cup_cx_m, bodies.y[b] - cup.cup_cy_m) > cup.cup_radius_m + d) continue;
    double x = 0, y = 0;
    cam.project(bodies.x[b], bodies.y[b], bodies.z[b], x, y);
    const double dpx = d * cam.px_per_m(bodies.z[b]);
    if (x < -dpx || y < -dpx || x > cam.width_px + dpx || y > cam.height_px + dpx) continue;
    const auto u = static_cast<double>(synth::splitmix64(look.seed ^ synth::splitmix64(
                                                              static_cast<std::uint64_t>(bodies.id[b]) + 1)) >>
                                       11) *
                   0x1.0p-53;
    double albedo = 1.0 + look.albedo_spread * (2.0 * u - 1.0);
    if (bodies.z[b] < surface_z_m) albedo *= std::exp(-(surface_z_m - bodies.z[b]) / (look.depth_fade_d * d));
    if (!bodies.mobile[b]) albedo *= 0.6;  // the floor's fixed beads: rougher, duller
    p.x.push_back(x);
    p.y.push_back(y);
    p.top.push_back((bodies.z[b] + 0.5 * d) * s_ref);
    p.diameter.push_back(dpx);
    p.albedo.push_back(albedo);
    p.id.push_back(bodies.id[b]);
  }
  return p;
}

CupImage cup_image(const synth::DownCamera& cam, const sim::FilmedCup& cup, double surface_z_m) {
  CupImage im;
  cam.project(cup.cup_cx_m, cup.cup_cy_m, surface_z_m, im.centre_x_px, im.centre_y_px);
  im.cup_radius_px = cup.cup_radius_m * cam.px_per_m(surface_z_m);
  im.rim_radius_px = cup.cup_radius_m * cam.px_per_m(cup.cup_height_m);
  if (cup.vane_blades > 0) {
    const double s = cam.px_per_m(cup.vane_height_m);
    im.vane_radius_px = cup.vane_radius_m * s;
    im.vane_half_width_px = 0.5 * cup.bead_diameter_m * s;
    im.vane_surface_radius_px = cup.vane_radius_m * cam.px_per_m(surface_z_m);
  }
  return im;
}

cv::Mat render_cup_frame(const synth::DownCamera& cam, const sim::FilmedCup& cup, double surface_z_m,
                         const ProjectedBeads& beads, double vane_angle_rad, const CupLook& look,
                         std::uint64_t frame) {
  const cv::Size size(cam.width_px, cam.height_px);
  cv::Mat ideal = synth::render_beads(beads.x, beads.y, beads.top, beads.albedo, beads.diameter, size, look.shading);
  // The rim: its top face a bright ring of rim_width_px beyond the wall's inner edge (the
  // line --detect-cup fits), the outside beyond it; inside it a dark band: the wall's
  // inner face (seen between the bead surface's and the rim's radius in a pinhole view)
  // and its shadow, at least 4 px or 0.3 d wide. Anti-aliased by 4 x 4 samples near edges.
  const CupImage im = cup_image(cam, cup, surface_z_m);
  const double R = im.rim_radius_px;
  const double d_px = cup.bead_diameter_m * cam.px_per_m(surface_z_m);
  const double R_in = R - std::max({4.0, 0.3 * d_px, R - im.cup_radius_px});
  const double R_out = R + look.rim_width_px;
  auto level_of = [&](double r) {  // at distance r from the axis' image
    if (r > R_out) return look.outside_level;
    return r > R ? look.rim_level : (r > R_in ? look.wall_level : -1.0);  // -1: the beads
  };
#pragma omp parallel for schedule(static)
  for (int i = 0; i < ideal.rows; ++i) {
    double* row = ideal.ptr<double>(i);
    for (int j = 0; j < ideal.cols; ++j) {
      const double r = std::hypot(j - im.centre_x_px, i - im.centre_y_px);
      if (r < R_in - 1.0) continue;
      if ((r > R_in + 1.0 && r < R - 1.0) || (r > R + 1.0 && r < R_out - 1.0) || r > R_out + 1.0) {
        row[j] = level_of(r);
        continue;
      }
      double acc = 0.0;
      for (int si = 0; si < 4; ++si)
        for (int sj = 0; sj < 4; ++sj) {
          const double v = level_of(std::hypot(j - 0.5 + (sj + 0.5) / 4 - im.centre_x_px,
                                               i - 0.5 + (si + 0.5) / 4 - im.centre_y_px));
          acc += v < 0 ? row[j] : v;
        }
      row[j] = acc / 16.0;
    }
  }
  if (cup.vane_blades > 0)
    synth::draw_vane(ideal, im.centre_x_px, im.centre_y_px, vane_angle_rad, cup.vane_blades, im.vane_half_width_px,
                     im.vane_radius_px, look.vane_level);
  if (look.blur_px > 0) cv::GaussianBlur(ideal, ideal, cv::Size(0, 0), look.blur_px, look.blur_px, cv::BORDER_REFLECT);
  cv::Mat out = synth::quantise(ideal, 0.0, look.noise, 8, look.seed, frame);
  if (look.jpeg_quality > 0) {
    std::vector<unsigned char> buf;
    cv::imencode(".jpg", out, buf, {cv::IMWRITE_JPEG_QUALITY, look.jpeg_quality});
    out = cv::imdecode(buf, cv::IMREAD_GRAYSCALE);
  }
  return out;
}

core::VectorField visible_motion(const ProjectedBeads& a, const ProjectedBeads& b, const std::vector<double>& xs,
                                 const std::vector<double>& ys, const CupImage& im, int blades, double vane_angle_a) {
  core::VectorField f;
  f.x_px = xs;
  f.y_px = ys;
  f.resize_to_grid();
  // Buckets of the frame-a discs.
  double cell = 1.0;
  for (const double d : a.diameter) cell = std::max(cell, d);
  auto key = [cell](double x, double y) {
    return std::pair<long, long>(static_cast<long>(std::floor(x / cell)), static_cast<long>(std::floor(y / cell)));
  };
  // A dense grid of cells over the discs' extent (the beads lie within the image, give
  // or take a diameter: project_beads drops the rest).
  long cx0 = 0, cy0 = 0, cx1 = -1, cy1 = -1;
  for (std::size_t k = 0; k < a.x.size(); ++k) {
    const auto [kx, ky] = key(a.x[k], a.y[k]);
    if (k == 0 || kx < cx0) cx0 = kx;
    if (k == 0 || ky < cy0) cy0 = ky;
    if (k == 0 || kx > cx1) cx1 = kx;
    if (k == 0 || ky > cy1) cy1 = ky;
  }
  const long ncx = cx1 - cx0 + 1, ncy = cy1 - cy0 + 1;
  std::vector<std::vector<std::size_t>> buckets(static_cast<std::size_t>(std::max(0L, ncx * ncy)));
  auto bucket = [&](long kx, long ky) -> const std::vector<std::size_t>* {
    if (kx < cx0 || kx > cx1 || ky < cy0 || ky > cy1) return nullptr;
    return &buckets[static_cast<std::size_t>((ky - cy0) * ncx + (kx - cx0))];
  };
  for (std::size_t k = 0; k < a.x.size(); ++k) {
    const auto [kx, ky] = key(a.x[k], a.y[k]);
    buckets[static_cast<std::size_t>((ky - cy0) * ncx + (kx - cx0))].push_back(k);
  }
  std::map<std::int64_t, std::size_t> in_b;
  for (std::size_t k = 0; k < b.id.size(); ++k) in_b.emplace(b.id[k], k);
  for (std::size_t i = 0; i < ys.size(); ++i) {
    for (std::size_t j = 0; j < xs.size(); ++j) {
      const std::size_t n = f.index(i, j);
      const double x = xs[j], y = ys[i];
      f.u_px[n] = f.v_px[n] = 0.0f;
      f.peak[n] = 1.0f;
      f.peak_ratio[n] = 10.0f;
      if (std::hypot(x - im.centre_x_px, y - im.centre_y_px) > im.cup_radius_px ||
          (blades > 0 && synth::inside_vane(x, y, im.centre_x_px, im.centre_y_px, vane_angle_a, blades,
                                            im.vane_half_width_px, im.vane_radius_px))) {
        f.flag[n] = core::VectorFlag::kMasked;
        continue;
      }
      const auto [cx, cy] = key(x, y);
      double best = -1e300;
      std::int64_t seen = -1;
      std::size_t seen_k = 0;
      for (long dy = -1; dy <= 1; ++dy)
        for (long dx = -1; dx <= 1; ++dx) {
          const std::vector<std::size_t>* members = bucket(cx + dx, cy + dy);
          if (members == nullptr) continue;
          for (const std::size_t k : *members) {
            const double R = 0.5 * a.diameter[k];
            const double rho2 = (x - a.x[k]) * (x - a.x[k]) + (y - a.y[k]) * (y - a.y[k]);
            if (rho2 >= R * R) continue;
            const double h = a.top[k] - R + std::sqrt(R * R - rho2);
            if (h > best) {
              best = h;
              seen = a.id[k];
              seen_k = k;
            }
          }
        }
      const auto hit = seen >= 0 ? in_b.find(seen) : in_b.end();
      if (hit == in_b.end()) {
        f.flag[n] = core::VectorFlag::kInvalid;
        continue;
      }
      f.u_px[n] = static_cast<float>(b.x[hit->second] - a.x[seen_k]);
      f.v_px[n] = static_cast<float>(b.y[hit->second] - a.y[seen_k]);
      f.flag[n] = core::VectorFlag::kValid;
    }
  }
  return f;
}

synth::DownCamera cup_camera(const sim::FilmedCup& cup, double surface_z_m, bool orthographic, int width_px,
                             int height_px, double m_per_px, double height_m) {
  synth::DownCamera c;
  c.orthographic = orthographic;
  c.width_px = width_px;
  c.height_px = height_px;
  c.centre_x_px = 0.5 * (width_px - 1);
  c.centre_y_px = 0.5 * (height_px - 1);
  c.axis_x_m = cup.cup_cx_m;
  c.axis_y_m = cup.cup_cy_m;
  c.z_ref_m = surface_z_m;
  c.height_m = height_m;
  if (core::is_set(m_per_px)) {
    c.m_per_px = m_per_px;
  } else {
    const double target_px = 0.45 * std::min(width_px, height_px);
    // The rim at the cup's top: R f / (height + z_ref - z_rim) = target, f = height / m.
    c.m_per_px = orthographic ? cup.cup_radius_m / target_px
                              : cup.cup_radius_m * height_m / ((height_m + surface_z_m - cup.cup_height_m) * target_px);
  }
  if (!orthographic && !(cup.cup_height_m < surface_z_m + height_m))
    throw ConfigError(fmt::format("--height-m {}: the pinhole must be above the cup's rim ({} m above the bead "
                                  "surface)",
                                  height_m, cup.cup_height_m - surface_z_m));
  c.validate();
  return c;
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

PivJobOptions camera_piv_options(const sim::FilmedCup& cup, const CupImage& image, double m_per_px,
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
  sum.camera = cup_camera(cup, sum.surface_z_m, o.projection == "orthographic", o.width_px, o.height_px, o.m_per_px,
                          o.height_m);
  const synth::DownCamera& cam = sum.camera;
  sum.image = cup_image(cam, cup, sum.surface_z_m);
  const CupImage& im = sum.image;
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
  io::CsvWriter angles(out.add("vane_angle.csv").stream(), meta, {"time_s", "angle_rad"});
  for (std::size_t k = 0; k < count; ++k) {
    const std::size_t fk = static_cast<std::size_t>(o.first_frame) + k;
    const sim::FrameBodies bodies = frames.frame(fk);
    const ProjectedBeads beads = project_beads(cam, cup, bodies, sum.surface_z_m, o.look);
    const double phi = cup.vane_angle(bodies.t_s);
    const cv::Mat img = render_cup_frame(cam, cup, sum.surface_z_m, beads, phi, o.look, fk);
    if (writer) {
      writer->write(img);
    } else {
      const std::string bytes = io::encode_image(img, o.output_dir / names[k]);
      out.add(names[k]).stream().write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    }
    angles.row(std::vector<double>{bodies.t_s - t_first, phi});
    if (progress) progress(k + 1, count);
  }
  if (writer) writer->close();

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
