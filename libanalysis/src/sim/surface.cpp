#include "shearzone/sim/surface.hpp"

#include <cmath>
#include <limits>
#include <numbers>
#include <utility>
#include <vector>

#include <Eigen/Geometry>
#include <unordered_map>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"

namespace shearzone::sim {

void SurfaceCameraOptions::validate() const {
  if (!(std::isfinite(m_per_px) && m_per_px > 0))
    throw ConfigError(fmt::format("surface camera: m_per_px = {}: expected > 0", m_per_px));
  if (!(spacing_px >= 1 && spacing_px <= 1024))
    throw ConfigError(fmt::format("surface camera: spacing {} px: expected 1..1024", spacing_px));
  if (!(width_px >= 1 && height_px >= 1 && width_px <= 65536 && height_px <= 65536))
    throw ConfigError(fmt::format("surface camera: image {}x{} px: expected 1..65536", width_px, height_px));
  if (!(std::isfinite(centre_x_px) && std::isfinite(centre_y_px) && std::isfinite(cx_m) && std::isfinite(cy_m)))
    throw ConfigError("surface camera: non-finite centre");
  if (!(cup_radius_m >= 0 && vane_radius_m >= 0 && std::isfinite(cup_radius_m) && std::isfinite(vane_radius_m)))
    throw ConfigError("surface camera: radii must be >= 0");
}

SurfaceCamera::SurfaceCamera(SurfaceCameraOptions o) : o_(o) {
  o_.validate();
  for (double x = 0.5 * o_.spacing_px - 0.5; x < o_.width_px; x += o_.spacing_px) xs_px_.push_back(x);
  for (double y = 0.5 * o_.spacing_px - 0.5; y < o_.height_px; y += o_.spacing_px) ys_px_.push_back(y);
}

namespace {

/// The image of x rotated by m wedges of a periodic sector about its axis (x itself
/// without a sector).
Vec3 image_of(const Options& o, const Vec3& x, int m) {
  if (o.sectors < 3 || m == 0) return x;
  const Vec3 c(o.sector_centre.x(), o.sector_centre.y(), 0.0);
  return c + Eigen::AngleAxisd(2.0 * std::numbers::pi * m / o.sectors, Vec3::UnitZ()) * (x - c);
}

}  // namespace

void SurfaceCamera::record(const World& w) {
  const std::size_t nx = xs_px_.size(), ny = ys_px_.size();
  seen_.assign(nx * ny, -1);
  image_.assign(nx * ny, 0);
  body_point_.assign(nx * ny, Vec3::Zero());
  world_point_.assign(nx * ny, Vec3::Zero());
  centre_.assign(nx * ny, Vec3::Zero());
  // A periodic sector is seen whole: every bead in each of its k images.
  const Options& opt = w.options();
  const int images = opt.sectors >= 3 ? opt.sectors : 1;
  // Mobile beads in a horizontal cell grid (cell = the largest diameter).
  double dmax = 0;
  for (int b = 0; b < w.body_count(); ++b)
    if (w.kind(b) == BodyKind::kMobile) dmax = std::max(dmax, w.diameter(b));
  std::unordered_map<std::int64_t, std::vector<std::pair<int, int>>> cells;  // (bead, image)
  auto cell_key = [](std::int64_t i, std::int64_t j) { return i * 4000037 + j; };
  const double cell = dmax > 0 ? dmax : 1.0;
  std::vector<Vec3> at(static_cast<std::size_t>(w.body_count()) * static_cast<std::size_t>(images));
  for (int b = 0; b < w.body_count(); ++b) {
    if (w.kind(b) != BodyKind::kMobile) continue;
    for (int m = 0; m < images; ++m) {
      const Vec3 x = image_of(opt, w.position(b), m);
      at[static_cast<std::size_t>(b) * static_cast<std::size_t>(images) + static_cast<std::size_t>(m)] = x;
      cells[cell_key(static_cast<std::int64_t>(std::floor(x.x() / cell)), static_cast<std::int64_t>(std::floor(x.y() / cell)))]
          .emplace_back(b, m);
    }
  }
  for (std::size_t i = 0; i < ny; ++i)
    for (std::size_t j = 0; j < nx; ++j) {
      const std::size_t n = i * nx + j;
      const double X = o_.cx_m + (xs_px_[j] - o_.centre_x_px) * o_.m_per_px;
      const double Y = o_.cy_m - (ys_px_[i] - o_.centre_y_px) * o_.m_per_px;
      const double r = std::hypot(X - o_.cx_m, Y - o_.cy_m);
      if ((o_.cup_radius_m > 0 && r > o_.cup_radius_m) || r < o_.vane_radius_m) {
        seen_[n] = -2;
        continue;
      }
      const auto ci = static_cast<std::int64_t>(std::floor(X / cell)), cj = static_cast<std::int64_t>(std::floor(Y / cell));
      int best = -1, best_image = 0;
      double top = -std::numeric_limits<double>::infinity();
      for (std::int64_t di = -1; di <= 1; ++di)
        for (std::int64_t dj = -1; dj <= 1; ++dj) {
          const auto it = cells.find(cell_key(ci + di, cj + dj));
          if (it == cells.end()) continue;
          for (const auto& [b, m] : it->second) {
            const Vec3& x = at[static_cast<std::size_t>(b) * static_cast<std::size_t>(images) + static_cast<std::size_t>(m)];
            const double rb = 0.5 * w.diameter(b);
            const double dx = X - x.x(), dy = Y - x.y(), h2 = rb * rb - dx * dx - dy * dy;
            if (h2 < 0) continue;
            const double z = x.z() + std::sqrt(h2);  // the bead surface above the node
            if (z > top || (z == top && (b < best || (b == best && m < best_image)))) {
              top = z;
              best = b;
              best_image = m;
            }
          }
        }
      if (best < 0) continue;
      const Vec3 p(X, Y, top);
      seen_[n] = best;
      image_[n] = best_image;
      world_point_[n] = p;
      centre_[n] = image_of(opt, w.position(best), best_image);
      // The point in the bead's frame (its image turned back into the wedge).
      body_point_[n] = w.orientation(best).conjugate() * (image_of(opt, p, -best_image) - w.position(best));
    }
}

core::VectorField SurfaceCamera::pair(const World& w) {
  if (seen_.empty()) throw InternalError("SurfaceCamera::pair before record");
  const Options& opt = w.options();
  const int images = opt.sectors >= 3 ? opt.sectors : 1;
  core::VectorField f;
  f.x_px = xs_px_;
  f.y_px = ys_px_;
  f.resize_to_grid();
  for (std::size_t n = 0; n < seen_.size(); ++n) {
    const int b = seen_[n];
    if (b == -2) {
      f.flag[n] = core::VectorFlag::kMasked;
      continue;
    }
    if (b < 0) {
      f.flag[n] = core::VectorFlag::kInvalid;
      continue;
    }
    // In a periodic sector the bead may have moved to another image since frame a: the
    // one nearest its centre then is the same bead.
    int m = image_[n];
    if (images > 1) {
      double nearest = std::numeric_limits<double>::infinity();
      for (int k = 0; k < images; ++k)
        if (const double dist = (image_of(opt, w.position(b), k) - centre_[n]).squaredNorm(); dist < nearest) {
          nearest = dist;
          m = k;
        }
    }
    const Vec3 now = image_of(opt, w.position(b) + w.orientation(b) * body_point_[n], m);
    const Vec3 d = now - world_point_[n];
    f.u_px[n] = static_cast<float>(d.x() / o_.m_per_px);
    f.v_px[n] = static_cast<float>(-d.y() / o_.m_per_px);
    f.peak[n] = 1.0f;
    f.peak_ratio[n] = 10.0f;
  }
  record(w);
  return f;
}

}  // namespace shearzone::sim
