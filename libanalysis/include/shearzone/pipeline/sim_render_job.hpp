// shearzone/pipeline/sim_render_job.hpp: `shearzone sim render`: the lab camera's view
// of a simulated cup, drawn from the run's frames.h5 (written by a run whose scene has
// a [camera]; sim_job.hpp).
//
// RUN/frames.h5 is read by sim::FramesFile (sim/frames_file.hpp: its layout).
//
// What OUT/ receives (all or nothing, io/atomic_output.hpp):
//   video.mp4 (or frame_000000.png ...)  8-bit grey frames at camera_fps, frame 0 at
//                                        the run's first frame (video time 0)
//   camera.json   the camera and the cup in pixels: m_per_px on the bead surface,
//                 centre, cup and vane radii, blades, drive, frame count, conventions
//   piv.toml      `shearzone piv VIDEO --config piv.toml` masks the vane from the
//                 drive and stores centre, radii, scale, N and the drive, so that
//                 `profile` and `width` need no geometry on the command line
//   vane_angle.csv  time_s (video time), angle_rad: the vane's angle log per frame
//
// The camera, the look and what it can see move: synth/cup_view.hpp.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "shearzone/core/metadata.hpp"
#include "shearzone/core/progress.hpp"
#include "shearzone/core/unset.hpp"
#include "shearzone/core/vector_field.hpp"
#include "shearzone/pipeline/piv_job.hpp"
#include "shearzone/sim/frames_file.hpp"
#include "shearzone/synth/camera.hpp"
#include "shearzone/synth/cup_view.hpp"

namespace shearzone::pipeline {


/// The cup of frames.h5 as the renderer draws it.
synth::CupGeometry filmed_geometry(const sim::FilmedCup& cup);
/// The bodies of one frame of frames.h5 as the renderer draws them (moved, not copied).
synth::CupBeads filmed_beads(sim::FrameBodies&& bodies);

/// The options of `shearzone piv` that a rendered camera fixes, on top of `base`: the
/// video's fps, the cup's centre, the annulus from the vane's surface radius to the
/// cup's, the vane's mask and drive (its phase in video time), and the root attributes
/// m_per_px, N, f_Hz, phi0_rad, cup_radius_px, vane_radius_px and bead_diameter_m (in
/// the order and form `piv --config piv.toml` gives them). `sim render` writes it as
/// piv.toml (camera_piv_toml), `sim check` runs it.
PivJobOptions camera_piv_options(const sim::FilmedCup& cup, const synth::CupImage& image, double m_per_px,
                                 double vane_phase_video_rad, PivJobOptions base = {});

/// piv.toml: the options camera_piv_options sets, by their long names.
std::string camera_piv_toml(const PivJobOptions& options);

struct SimRenderOptions {
  std::filesystem::path run_dir;      ///< a run folder holding frames.h5
  std::filesystem::path output_dir;
  std::string format = "mp4";         ///< mp4 | png
  std::string codec = "mp4v";         ///< mp4v | avc1 (H.264 where FFmpeg has it)
  std::string projection = "pinhole"; ///< pinhole | orthographic
  int width_px = 1280, height_px = 720;
  double m_per_px = core::kUnset;     ///< on the bead surface; unset: the cup fills the image
  double height_m = 0.5;              ///< pinhole above the bead surface
  synth::CupLook look;
  std::int64_t first_frame = 0, last_frame = -1;  ///< frames of frames.h5 drawn (-1: to the end)
  bool force = false;
  /// ConfigError naming the bad option (before any file is read).
  void validate() const;
};

struct SimRenderSummary {
  std::size_t frames = 0;
  synth::DownCamera camera;
  synth::CupImage image;
  double surface_z_m = 0.0;
  double bead_diameter_px = 0.0;  ///< on the bead surface
  double seconds = 0.0;
  std::vector<std::filesystem::path> files;
};

SimRenderSummary run_sim_render(const SimRenderOptions& options, const core::Metadata& header,
                                const core::ProgressCallback& progress = {});

}  // namespace shearzone::pipeline
