// shearzone/sim/surface.hpp: the top surface of a simulated cup as a virtual camera sees
// it: a PIV-like vector field whose truth is the beads' own motion.
//
// An orthographic camera looks down the -z axis. Image axes follow the project's
// convention: pixel centres at integers, x to the right along world +X, y downwards along
// world -Y, the cup axis at (centre_x_px, centre_y_px); so a rotation counter-clockwise
// seen from above is counter-clockwise on the image, as v_theta > 0 (core/conventions.hpp).
// Grid nodes sit at spacing/2 - 1/2 + i spacing px, like the PIV's window centres.
// What a node sees: the top-most mobile bead whose horizontal disc (radius d/2 about its
// centre) contains the node, i.e. the bead surface point straight above the node's
// world position (a "surface bead" is a bead that some node sees). Its value for a pair
// of frames (a, b) is the displacement, in px, of that material point of the bead
// (centre and orientation at frame b against frame a, rigid body), so spin counts as
// it would in the video. Flags: `masked` inside the vane's disc (r < vane radius) and
// outside the cup (r > cup radius); `invalid` where no mobile bead covers the node;
// `valid` otherwise (peak 1, peak ratio 10: exact values). A periodic sector
// (Options::sectors = k) is seen as the whole cup: each bead in its k images.
#pragma once

#include <cstddef>
#include <vector>

#include "shearzone/core/vector_field.hpp"
#include "shearzone/sim/world.hpp"

namespace shearzone::sim {

struct SurfaceCameraOptions {
  double m_per_px = 1e-4;          ///< scale
  double spacing_px = 8.0;         ///< grid step
  int width_px = 640, height_px = 640;
  double centre_x_px = 319.5, centre_y_px = 319.5;  ///< image of the point (cx, cy) of the world
  double cx_m = 0.0, cy_m = 0.0;   ///< the cup axis in the world (x, y)
  double cup_radius_m = 0.0;       ///< nodes beyond are masked (0: none)
  double vane_radius_m = 0.0;      ///< nodes within are masked (0: none)
  /// ConfigError naming the bad option.
  void validate() const;
};

/// What a frame records: which bead each node sees and where that material point is
/// in the bead's frame (so the next frame can follow it).
class SurfaceCamera {
 public:
  explicit SurfaceCamera(SurfaceCameraOptions o);
  const SurfaceCameraOptions& options() const { return o_; }
  /// Records frame a from the world's present state.
  void record(const World& w);
  /// The field of the pair (frame a recorded last, frame b = the world now): per node the
  /// displacement of the seen material point, px. Then frame b becomes frame a.
  core::VectorField pair(const World& w);
  bool has_frame() const { return !seen_.empty(); }

 private:
  SurfaceCameraOptions o_;
  std::vector<double> xs_px_, ys_px_;
  std::vector<int> seen_;              // per node: the bead, -1 none, -2 masked
  std::vector<Vec3> body_point_;       // per node: the point in the bead's frame
  std::vector<Vec3> world_point_;      // per node: the point in the world at frame a
  std::vector<int> image_;             // per node: the bead's image (periodic sector), 0 else
  std::vector<Vec3> centre_;           // per node: that image's centre at frame a
};

}  // namespace shearzone::sim
