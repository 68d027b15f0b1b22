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
// The look (synth/render.hpp, the `synth beads` model): shaded steel spheres with a
// specular highlight, lower beads darker by depth (and hidden by the ones above); the
// cup's rim as a bright ring (its top face, rim_width_px wide beyond the wall's inner
// edge: the line that `profile --detect-cup` fits) with a dark band inside it (the
// wall's inner face and its shadow); opaque dark vane blades; then optional blur,
// sensor noise and JPEG compression. Every random number is seeded from `seed`, the
// bead and the frame, so two renders of a run are the same bytes (PNG).
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
#include "shearzone/synth/render.hpp"

namespace shearzone::pipeline {


/// Beads as the camera projects them: px centres, tops (px, for depth order: higher
/// hides lower), diameters (px) and albedos, with the id of sim::FrameBodies.
struct ProjectedBeads {
  std::vector<double> x, y, top, diameter, albedo;
  std::vector<std::int64_t> id;
};

struct CupLook {
  synth::BeadShading shading;
  double rim_level = 0.9;      ///< the rim's top face: a bright ring beyond the cup radius
  double rim_width_px = 4.0;   ///< its width
  double outside_level = 0.15; ///< beyond the rim
  double wall_level = 0.04;    ///< the wall's inner face and shadow, a band inside the rim
  double vane_level = 0.12;    ///< the vane blades
  double depth_fade_d = 1.0;   ///< beads darken by e per this many diameters below the surface
  double albedo_spread = 0.1;  ///< per-bead albedo scatter (uniform, +-), seeded by bead
  double noise = 0.01;         ///< sensor noise, fraction of full scale (Gaussian)
  double blur_px = 0.0;        ///< Gaussian blur sigma before the noise, px (0: none)
  int jpeg_quality = 0;        ///< 1..100: each frame through JPEG at this quality; 0: none
  std::uint64_t seed = 1;
  /// ConfigError naming the bad value.
  void validate() const;
};

/// Projects the beads of a frame (beads beyond the image are dropped).
ProjectedBeads project_beads(const synth::DownCamera& camera, const sim::FilmedCup& cup, const sim::FrameBodies& bodies,
                             double surface_z_m, const CupLook& look);

/// The image of the vane's blades and the cup's rim as drawn (px).
struct CupImage {
  double centre_x_px = 0, centre_y_px = 0;
  double cup_radius_px = 0;      ///< the cup's wall at the bead surface (the profile's R)
  double rim_radius_px = 0;      ///< the wall's inner edge at the rim (the rim's face starts there)
  double vane_radius_px = 0, vane_half_width_px = 0;  ///< the blades as drawn (at the vane's top)
  double vane_surface_radius_px = 0;  ///< the vane's radius on the bead surface (the profile's R_v)
};
CupImage cup_image(const synth::DownCamera& camera, const sim::FilmedCup& cup, double surface_z_m);

/// One 8-bit frame: beads, rim, vane at angle `vane_angle_rad`, blur, noise (seeded by
/// look.seed and `frame`), compression.
cv::Mat render_cup_frame(const synth::DownCamera& camera, const sim::FilmedCup& cup, double surface_z_m,
                         const ProjectedBeads& beads, double vane_angle_rad, const CupLook& look,
                         std::uint64_t frame);

/// What the camera can see move between frames a and b, per node of the grid (x_px,
/// y_px): the displacement (px) of the projected centre of the bead whose surface is
/// top-most over the node in frame a (render_beads' depth rule), to its projection in
/// frame b. Shiny spheres show their centres' motion, not their spin, so this, not the
/// material-point field of surface.h5, is what PIV of the video can recover. Flags:
/// masked beyond the cup radius and on the vane (at `vane_angle_a`); invalid where no
/// bead covers the node or its bead is not in frame b; valid otherwise.
core::VectorField visible_motion(const ProjectedBeads& a, const ProjectedBeads& b, const std::vector<double>& x_px,
                                 const std::vector<double>& y_px, const CupImage& image, int vane_blades,
                                 double vane_angle_a);

/// The camera over a cup: the axis at the image centre; m_per_px unset: the rim's
/// diameter fills 90 % of the image's shorter side.
synth::DownCamera cup_camera(const sim::FilmedCup& cup, double surface_z_m, bool orthographic, int width_px,
                             int height_px, double m_per_px, double height_m);

/// The options of `shearzone piv` that a rendered camera fixes, on top of `base`: the
/// video's fps, the cup's centre, the annulus from the vane's surface radius to the
/// cup's, the vane's mask and drive (its phase in video time), and the root attributes
/// m_per_px, N, f_Hz, phi0_rad, cup_radius_px, vane_radius_px and bead_diameter_m (in
/// the order and form `piv --config piv.toml` gives them). `sim render` writes it as
/// piv.toml (camera_piv_toml), `sim check` runs it.
PivJobOptions camera_piv_options(const sim::FilmedCup& cup, const CupImage& image, double m_per_px,
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
  CupLook look;
  std::int64_t first_frame = 0, last_frame = -1;  ///< frames of frames.h5 drawn (-1: to the end)
  bool force = false;
  /// ConfigError naming the bad option (before any file is read).
  void validate() const;
};

struct SimRenderSummary {
  std::size_t frames = 0;
  synth::DownCamera camera;
  CupImage image;
  double surface_z_m = 0.0;
  double bead_diameter_px = 0.0;  ///< on the bead surface
  double seconds = 0.0;
  std::vector<std::filesystem::path> files;
};

SimRenderSummary run_sim_render(const SimRenderOptions& options, const core::Metadata& header,
                                const core::ProgressCallback& progress = {});

}  // namespace shearzone::pipeline
