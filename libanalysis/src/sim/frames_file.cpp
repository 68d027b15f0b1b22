#include "shearzone/sim/frames_file.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/io/hdf5.hpp"
#include "shearzone/sim/scene.hpp"
#include "shearzone/sim/world.hpp"

namespace shearzone::sim {
namespace {

constexpr double kPi = std::numbers::pi;

double attr_number(const io::H5File& f, const std::string& name, bool required, double fallback = 0.0) {
  if (!f.has_attribute("/", name)) {
    if (required)
      throw InputError(fmt::format("{}: attribute \"{}\" missing: expected the frames file of a run with a "
                                   "[camera] (shearzone sim)",
                                   f.path(), name));
    return fallback;
  }
  const std::string text = f.attribute_string("/", name);
  double v = 0.0;
  if (!io::parse_number(text, false, v) || !std::isfinite(v))
    throw InputError(fmt::format("{}: attribute \"{}\" = \"{}\": expected a finite number", f.path(), name, text));
  return v;
}

}  // namespace

double FilmedCup::vane_angle(double t_s) const {
  return phi0_rad * std::sin(2.0 * kPi * f_Hz * t_s + vane_phase_rad);
}

FramesFile::FramesFile(const std::filesystem::path& path) : path_(path.string()) {
  if (!std::filesystem::exists(path))
    throw InputError(fmt::format("{}: not found: expected the frames of a run whose scene has a [camera] with "
                                 "frames = true",
                                 path_));
  file_ = std::make_unique<io::H5File>(io::H5File::open_read(path));
  const io::H5File& f = *file_;
  FilmedCup& c = cup_;
  c.fps = attr_number(f, "camera_fps", true);
  c.bead_diameter_m = attr_number(f, "bead_diameter_m", true);
  c.N = static_cast<int>(attr_number(f, "N", false, 1.0));
  c.cup_cx_m = attr_number(f, "cup_centre_x_m", true);
  c.cup_cy_m = attr_number(f, "cup_centre_y_m", true);
  c.cup_radius_m = attr_number(f, "cup_radius_m", true);
  c.cup_height_m = attr_number(f, "cup_height_m", true);
  c.sectors = static_cast<int>(attr_number(f, "sectors", false, 0.0));
  c.vane_blades = static_cast<int>(attr_number(f, "vane_blades", false, 0.0));
  c.vane_radius_m = attr_number(f, "vane_radius_m", false, 0.0);
  c.vane_height_m = attr_number(f, "vane_height_m", false, 0.0);
  c.f_Hz = attr_number(f, "f_Hz", false, 0.0);
  c.phi0_rad = attr_number(f, "phi0_rad", false, 0.0);
  c.vane_phase_rad = attr_number(f, "vane_phase_rad", false, 0.0);
  if (!(c.fps > 0 && c.bead_diameter_m > 0 && c.cup_radius_m > 0 && c.cup_height_m > 0 && c.sectors >= 0 &&
        c.sectors <= 64 && c.vane_blades >= 0 && c.vane_blades <= 64 && c.vane_radius_m >= 0 &&
        c.vane_radius_m < c.cup_radius_m && c.N >= 1))
    throw InputError(fmt::format("{}: the scene attributes are out of range (camera_fps, bead_diameter_m, "
                                 "cup_radius_m, cup_height_m > 0; 0 <= vane_radius_m < cup_radius_m)",
                                 path_));
  times_ = f.read<double>("/time_s").data;
  const io::H5Array<std::uint8_t> kind = f.read<std::uint8_t>("/kind");
  kind_ = kind.data;
  const std::vector<std::size_t> pd = f.dims("/position");
  if (pd.size() != 3 || pd[0] != times_.size() || pd[1] != kind_.size() || pd[2] != 3)
    throw InputError(fmt::format("{}: dataset \"/position\": expected [{}, {}, 3]", path_, times_.size(),
                                 kind_.size()));
  if (times_.empty()) throw InputError(fmt::format("{}: no frame recorded", path_));
  // The bead surface: the 90th percentile of the mobile centres' heights in frame 0.
  std::vector<double> pos(kind_.size() * 3);
  f.read_record("/position", 0, pos.data());
  std::vector<double> zs;
  for (std::size_t b = 0; b < kind_.size(); ++b)
    if (kind_[b] == 0) zs.push_back(pos[3 * b + 2]);
  if (zs.empty()) throw InputError(fmt::format("{}: no mobile bead to film", path_));
  const auto q = static_cast<std::ptrdiff_t>(std::floor(0.9 * static_cast<double>(zs.size() - 1)));
  std::nth_element(zs.begin(), zs.begin() + q, zs.end());
  surface_z_ = zs[static_cast<std::size_t>(q)];
}

FramesFile::~FramesFile() = default;

FrameBodies FramesFile::frame(std::size_t k) const {
  std::vector<double> pos(kind_.size() * 3);
  file_->read_record("/position", k, pos.data());
  FrameBodies out;
  out.t_s = times_.at(k);
  const int images = std::max(1, cup_.sectors);
  for (int j = 0; j < images; ++j) {
    const double a = 2.0 * kPi * j / images, ca = std::cos(a), sa = std::sin(a);
    for (std::size_t b = 0; b < kind_.size(); ++b) {
      if (kind_[b] == 2) continue;  // the vane: drawn from its drive
      const double dx = pos[3 * b] - cup_.cup_cx_m, dy = pos[3 * b + 1] - cup_.cup_cy_m;
      out.x.push_back(cup_.cup_cx_m + ca * dx - sa * dy);
      out.y.push_back(cup_.cup_cy_m + sa * dx + ca * dy);
      out.z.push_back(pos[3 * b + 2]);
      out.id.push_back(static_cast<std::int64_t>(b) * images + j);
      out.mobile.push_back(kind_[b] == 0);
    }
  }
  return out;
}

void add_frames_metadata(core::Metadata& m, const SceneCamera& sc, int beads_per_chain, const World& w) {
  auto num = [](double v) { return io::format_number(v); };
  m.emplace_back("frames", "the bodies at the camera's frames: record k is frame k of surface.h5 (its pair k "
                           "runs from record k to record k + 1)");
  m.emplace_back("camera_fps", num(sc.fps));
  m.emplace_back("bead_diameter_m", num(sc.bead_diameter_m));
  m.emplace_back("N", std::to_string(beads_per_chain));
  m.emplace_back("cup_centre_x_m", num(sc.options.cx_m));
  m.emplace_back("cup_centre_y_m", num(sc.options.cy_m));
  m.emplace_back("cup_radius_m", num(sc.options.cup_radius_m));
  m.emplace_back("cup_height_m", num(sc.cup_height_m));
  m.emplace_back("sectors", std::to_string(w.options().sectors));
  m.emplace_back("vane_blades", std::to_string(w.rotor_count() > 0 ? sc.vane_blades : 0));
  m.emplace_back("vane_radius_m", num(sc.options.vane_radius_m));
  m.emplace_back("vane_height_m", num(sc.vane_height_m));
  if (w.rotor_count() > 0) {
    const Rotor& r = w.rotor(0);
    m.emplace_back("f_Hz", num(r.f_Hz));
    m.emplace_back("phi0_rad", num(r.phi0));
    m.emplace_back("vane_phase_rad", num(r.phase - 2.0 * std::numbers::pi * r.f_Hz * r.t_start));
    m.emplace_back("vane_angle", "phi(t) = phi0_rad sin(2 pi f_Hz t + vane_phase_rad), t = time_s; blade j at "
                                 "azimuth phi + 2 pi j / vane_blades, counter-clockwise seen from above (+z)");
  }
}

}  // namespace shearzone::sim
