#include "shearzone/pipeline/synth_job.hpp"

#include "shearzone/synth/field.hpp"

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/io/atomic_output.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/io/image.hpp"
#include "shearzone/io/video.hpp"

namespace shearzone::pipeline {
namespace {

bool is_video_format(const std::string& f) { return f == "mp4" || f == "avi"; }

std::string extension_of(const std::string& format) {
  if (format == "tiff") return ".tif";
  return "." + format;
}

}  // namespace

void SynthJobOptions::validate() const {
  synth.validate();
  if (format != "png" && format != "tiff" && format != "mp4" && format != "avi")
    throw ConfigError(
        fmt::format("unknown format \"{}\"; expected one of: png, tiff, mp4, avi", format));
  if (is_video_format(format) && synth.image.bit_depth != 8)
    throw ConfigError(fmt::format("format {} holds 8-bit frames only; got bit_depth = {} (use "
                                  "png or tiff for 16-bit)",
                                  format, synth.image.bit_depth));
  if (format == "mp4" && video_codec != "mp4v" && video_codec != "avc1")
    throw ConfigError(fmt::format("--codec \"{}\": expected mp4v or avc1 for mp4 (avi uses MJPG)",
                                  video_codec));
  if (!(truth_spacing_px >= 1))
    throw ConfigError(
        fmt::format("truth_spacing_px = {}: must be >= 1", io::format_number(truth_spacing_px)));
  if (out_dir.empty()) throw ConfigError("no output folder given");
}

SynthJobSummary run_synth_job(const SynthJobOptions& options, const core::Metadata& header,
                              const core::ProgressCallback& progress) {
  // Step 1: validate everything cheap, including that no output would be overwritten.
  options.validate();
  const auto& so = options.synth;
  const int K = so.sequence.frames;
  const bool video = is_video_format(options.format);
  const bool pair = K == 2 && !video;
  const std::string ext = extension_of(options.format);

  std::vector<std::string> frame_names;
  if (video) {
    frame_names.push_back("video" + ext);
  } else if (pair) {
    frame_names = {"A" + ext, "B" + ext};
  } else {
    for (int k = 0; k < K; ++k) frame_names.push_back(fmt::format("frame_{:06d}{}", k, ext));
  }
  io::AtomicOutputSet out(options.out_dir, options.force);
  for (const auto& n : frame_names) out.check(n);
  out.check("truth.csv");
  out.check("frames.csv");

  // Step 2: place tracers and render the frames.
  synth::FrameGenerator gen(so);
  core::Metadata meta = header;
  for (auto& kv : gen.options().to_metadata()) meta.push_back(std::move(kv));

  std::unique_ptr<io::VideoWriter> writer;
  if (video) {
    auto& f = out.add(frame_names[0]);
    const std::string codec = options.format == "avi" ? "MJPG" : options.video_codec;
    writer = std::make_unique<io::VideoWriter>(f.temp_path(), so.sequence.fps,
                                               cv::Size(so.image.width_px, so.image.height_px), codec,
                                               f.final_path());  // named in messages, not the temporary
  }
  while (!gen.done()) {
    const int k = gen.next_index();
    const cv::Mat frame = gen.next();
    if (video) {
      writer->write(frame);
    } else {
      const std::string& name = frame_names[static_cast<std::size_t>(k)];
      const std::string bytes = io::encode_image(frame, options.out_dir / name);
      out.add(name).stream().write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    }
    if (progress) progress(static_cast<std::size_t>(k + 1), static_cast<std::size_t>(K));
  }
  if (writer) writer->close();

  // Step 3: ground truth and frame times.
  {
    core::Metadata m = meta;
    const double scale = pair ? gen.frame_time(0).pair_scale : 1.0;
    m.emplace_back("truth", pair ? "exact displacement from frame A to frame B, px"
                                 : "displacement per frame at disp_scale = 1, px; the pair (k, "
                                   "k+1) moves disp_scale_k times this (frames.csv)");
    m.emplace_back("truth_grid_spacing_px", io::format_number(options.truth_spacing_px));
    io::CsvWriter w(out.add("truth.csv").stream(), m, {"x_px", "y_px", "u_px", "v_px"});
    for (const auto& p : gen.truth(options.truth_spacing_px, scale))
      w.row(std::vector<double>{p.x_px, p.y_px, p.u_px, p.v_px});
  }
  {
    core::Metadata m = meta;
    m.emplace_back("columns", "frame: index; t_s: k/fps; phi_rad: vane angle phi0*sin(2*pi*f*t) "
                              "(CCW positive as the camera sees it); disp_scale: scale of the "
                              "displacement from this frame to the next");
    io::CsvWriter w(out.add("frames.csv").stream(), m, {"frame", "t_s", "phi_rad", "disp_scale"});
    for (int k = 0; k < K; ++k) {
      const auto ft = gen.frame_time(k);
      w.row(std::vector<double>{static_cast<double>(k), ft.t_s, ft.phi_rad, ft.pair_scale});
    }
  }

  // Step 4: everything appears at once.
  out.commit_all();
  SynthJobSummary summary;
  summary.files = out.final_paths();
  summary.tracers = gen.num_tracers();
  summary.frames = K;
  summary.resolved_options = gen.options().to_metadata();
  return summary;
}

synth::FieldKind synth_field_kind(const std::string& name) { return synth::field_kind_from_name(name); }

}  // namespace shearzone::pipeline
