// The periodic sector's geometry: see sector.hpp.
#include "sector.hpp"

#include <cmath>
#include <numbers>

namespace shearzone::sim {

namespace detail {

Sector::Sector(const Options& o) {
  if (o.sectors < 3) return;
  on = true;
  width = 2.0 * std::numbers::pi / o.sectors;
  c = std::cos(width);
  s = std::sin(width);
  if (o.sectors == 4) {  // exact quarter turns
    c = 0.0;
    s = 1.0;
  }
  cx = o.sector_centre.x();
  cy = o.sector_centre.y();
  start = o.sector_start;
  nx = -std::sin(start);
  ny = std::cos(start);
}

int Sector::wedges(const Vec3& x) const {
  if (!on) return 0;
  const double dx = x.x() - cx, dy = x.y() - cy;
  if (dx == 0.0 && dy == 0.0) return 0;
  const int k = static_cast<int>(std::lround(2.0 * std::numbers::pi / width));
  int m = static_cast<int>(std::floor((std::atan2(dy, dx) - start) / width));
  m = ((m % k) + k) % k;  // the nearest turn: in (−k/2, k/2]
  return 2 * m > k ? m - k : m;
}

}  // namespace detail

bool sector_contains(const Options& options, const Vec3& x) { return detail::Sector(options).wedges(x) == 0; }

}  // namespace shearzone::sim
