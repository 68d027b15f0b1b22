// shearzone/sim/frames_file.hpp: reading frames.h5, the bodies at a run's camera frames
// (sim_job writes it with SnapshotWriter, sim/sim_io.hpp: one record per camera frame,
// record k = frame k of surface.h5) and the scene a renderer needs as root attributes:
// camera_fps, bead_diameter_m, N, cup_centre_x_m, cup_centre_y_m, cup_radius_m,
// cup_height_m, sectors, vane_blades, vane_radius_m, vane_height_m, and for a driven
// vane f_Hz, phi0_rad, vane_phase_rad (phi(t) = phi0 sin(2 pi f t + vane_phase_rad)),
// run_id. `shearzone sim render` and `sim check` read it; add_frames_metadata writes the
// attributes (all but run_id), so both sides name them here.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "shearzone/core/metadata.hpp"

namespace shearzone::io {
class H5File;
}  // namespace shearzone::io

namespace shearzone::sim {

struct SceneCamera;
class World;

/// The cup that frames.h5 describes (SI units).
struct FilmedCup {
  double fps = 25.0;
  double bead_diameter_m = 0.0;
  int N = 1;
  double cup_cx_m = 0.0, cup_cy_m = 0.0, cup_radius_m = 0.0, cup_height_m = 0.0;
  int sectors = 0;                      ///< periodic 1/k of the cup (drawn whole), 0: whole
  int vane_blades = 0;                  ///< 0: no vane
  double vane_radius_m = 0.0, vane_height_m = 0.0;
  double f_Hz = 0.0, phi0_rad = 0.0, vane_phase_rad = 0.0;
  /// phi(t) = phi0 sin(2 pi f t + vane_phase_rad).
  [[nodiscard]] double vane_angle(double t_s) const;
};

/// The bodies of one frame that the camera sees (mobile and fixed beads; the vane is
/// drawn from its drive). A periodic sector's bodies appear in every image, rotated by
/// 2 pi j / sectors; id = body index * max(1, sectors) + j names a bead across frames.
struct FrameBodies {
  double t_s = 0.0;  ///< simulated time
  std::vector<double> x, y, z;
  std::vector<std::int64_t> id;
  std::vector<bool> mobile;
};

/// frames.h5's root attributes for the camera of a scene whose chains hold
/// `beads_per_chain` beads, in world `w` (the vane's drive from its first rotor),
/// appended to `m`.
void add_frames_metadata(core::Metadata& m, const SceneCamera& camera, int beads_per_chain, const World& w);

/// Reads frames.h5 (InputError naming the file and what is wrong).
class FramesFile {
 public:
  explicit FramesFile(const std::filesystem::path& path);
  ~FramesFile();
  FramesFile(const FramesFile&) = delete;
  FramesFile& operator=(const FramesFile&) = delete;
  [[nodiscard]] const FilmedCup& cup() const { return cup_; }
  [[nodiscard]] std::size_t size() const { return times_.size(); }
  [[nodiscard]] double time(std::size_t k) const { return times_.at(k); }
  [[nodiscard]] FrameBodies frame(std::size_t k) const;
  /// The bead surface's height: the 90th percentile of the mobile beads' centre heights
  /// in frame 0 (the plane PIV measures on).
  [[nodiscard]] double surface_z_m() const { return surface_z_; }
  [[nodiscard]] const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::unique_ptr<io::H5File> file_;  ///< open for the frames' reads (one thread)
  FilmedCup cup_;
  std::vector<double> times_;
  std::vector<std::uint8_t> kind_;
  double surface_z_ = 0.0;
};

}  // namespace shearzone::sim
