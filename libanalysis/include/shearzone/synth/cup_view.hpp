// shearzone/synth/cup_view.hpp: a cup of beads as the lab camera films it from above
// (the renderer behind `shearzone sim render` and `sim check`), and the motion that
// camera can see.
//
// The look (render.hpp, the `synth beads` model): shaded steel spheres with a specular
// highlight, lower beads darker by depth (and hidden by the ones above); the cup's rim
// as a bright ring (its top face, rim_width_px wide beyond the wall's inner edge: the
// line that `profile --detect-cup` fits) with a dark band inside it (the wall's inner
// face and its shadow); opaque dark vane blades; then optional blur, sensor noise and
// JPEG compression. Every random number is seeded from `seed`, the bead and the frame,
// so two renders are the same bytes.
//
// World: metres, +z up, the cup's axis vertical (camera.hpp); images in the project's
// pixel convention (core/conventions.hpp).
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "shearzone/core/vector_field.hpp"
#include "shearzone/synth/camera.hpp"
#include "shearzone/synth/render.hpp"

namespace shearzone::synth {

/// The cup and its vane (world metres).
struct CupGeometry {
  double bead_diameter_m = 0.0;
  double centre_x_m = 0.0, centre_y_m = 0.0;  ///< the axis
  double radius_m = 0.0, height_m = 0.0;      ///< the wall's inner radius, the rim's height
  int vane_blades = 0;                        ///< 0: no vane
  double vane_radius_m = 0.0, vane_height_m = 0.0;
};

/// The bead centres of one frame (world metres). id names a bead across frames; fixed
/// beads (mobile false: the floor's) are drawn duller.
struct CupBeads {
  std::vector<double> x, y, z;
  std::vector<std::int64_t> id;
  std::vector<bool> mobile;
};

/// Beads as the camera projects them: px centres, tops (px, for depth order: higher
/// hides lower), diameters (px) and albedos, with the id of CupBeads.
struct ProjectedBeads {
  std::vector<double> x, y, top, diameter, albedo;
  std::vector<std::int64_t> id;
};

struct CupLook {
  BeadShading shading;
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

/// The camera over a cup: the axis at the image centre; m_per_px unset: the rim's
/// diameter fills 90 % of the image's shorter side. ConfigError if a pinhole would sit
/// at or below the rim.
DownCamera cup_camera(const CupGeometry& cup, double surface_z_m, bool orthographic, int width_px, int height_px,
                      double m_per_px, double height_m);

/// Projects the beads of a frame (beads beyond the image or under the rim are dropped).
ProjectedBeads project_beads(const DownCamera& camera, const CupGeometry& cup, const CupBeads& beads,
                             double surface_z_m, const CupLook& look);

/// The image of the vane's blades and the cup's rim as drawn (px).
struct CupImage {
  double centre_x_px = 0, centre_y_px = 0;
  double cup_radius_px = 0;      ///< the cup's wall at the bead surface (the profile's R)
  double rim_radius_px = 0;      ///< the wall's inner edge at the rim (the rim's face starts there)
  double vane_radius_px = 0, vane_half_width_px = 0;  ///< the blades as drawn (at the vane's top)
  double vane_surface_radius_px = 0;  ///< the vane's radius on the bead surface (the profile's R_v)
};
CupImage cup_image(const DownCamera& camera, const CupGeometry& cup, double surface_z_m);

/// One 8-bit frame: beads, rim, vane at angle `vane_angle_rad`, blur, noise (seeded by
/// look.seed and `frame`), compression.
cv::Mat render_cup_frame(const DownCamera& camera, const CupGeometry& cup, double surface_z_m,
                         const ProjectedBeads& beads, double vane_angle_rad, const CupLook& look,
                         std::uint64_t frame);

/// What the camera can see move between frames a and b, per node of the grid (x_px,
/// y_px): the displacement (px) of the projected centre of the bead whose surface is
/// top-most over the node in frame a (render_beads' depth rule), to its projection in
/// frame b. Shiny spheres show their centres' motion, not their spin, so this, not the
/// material-point field of a simulation's surface, is what PIV of the video can
/// recover. Flags: masked beyond the cup radius and on the vane (at `vane_angle_a`);
/// invalid where no bead covers the node or its bead is not in frame b; valid otherwise.
core::VectorField visible_motion(const ProjectedBeads& a, const ProjectedBeads& b, const std::vector<double>& x_px,
                                 const std::vector<double>& y_px, const CupImage& image, int vane_blades,
                                 double vane_angle_a);

/// The beads whose middle is visible in frame a (no higher bead over the centre or the
/// four points a quarter diameter from it: a bead a tracker can find), not
/// masked (cup radius, vane at `vane_angle_a`) and present in frame b: their projected
/// centres in a and displacements to b (px). What a bead tracker can at best recover, bead
/// by bead: the reference of `piv --method track` in `sim check`.
struct VisibleBeads {
  std::vector<double> x_px, y_px, u_px, v_px;
};
VisibleBeads visible_beads(const ProjectedBeads& a, const ProjectedBeads& b, const CupImage& image, int vane_blades,
                           double vane_angle_a);

}  // namespace shearzone::synth
