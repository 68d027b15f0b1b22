#include "shearzone/sim/scenario.hpp"

#include <algorithm>
#include <cmath>
#include <random>

#include "shearzone/sim/builder.hpp"

namespace shearzone::sim {

void add_box_pour(World& w, const BoxPour& o) {
  const double d = o.diameter, half = o.half_width;
  w.add_wall(Wall{Vec3::Zero(), Vec3::UnitZ(), o.wall_friction});
  w.add_wall(Wall{Vec3(-half, 0, 0), Vec3::UnitX(), o.wall_friction});
  w.add_wall(Wall{Vec3(half, 0, 0), -Vec3::UnitX(), o.wall_friction});
  w.add_wall(Wall{Vec3(0, -half, 0), Vec3::UnitY(), o.wall_friction});
  w.add_wall(Wall{Vec3(0, half, 0), -Vec3::UnitY(), o.wall_friction});
  std::mt19937_64 rng(o.seed);
  std::uniform_real_distribution<double> jitter(-o.jitter * d, o.jitter * d);
  const int n = o.per_row;
  int made = 0;
  for (int layer = 0; made < o.beads; ++layer)
    for (int iy = 0; iy < n && made < o.beads; ++iy)
      for (int ix = 0; ix < n && made < o.beads; ++ix, ++made)
        w.add_sphere(Vec3((ix - 0.5 * (n - 1)) * o.pitch * d + jitter(rng),
                          (iy - 0.5 * (n - 1)) * o.pitch * d + jitter(rng), (o.z0 + o.layer_dz * layer) * d),
                     d, o.density);
}

LatticePourLayout add_lattice_pour(World& w, const LatticePour& o) {
  const double d = o.diameter, a = o.pitch * d;
  const int n = std::max(2, static_cast<int>(std::ceil(std::cbrt(static_cast<double>(o.count)))));
  const double side = n * a;
  std::mt19937_64 rng(o.seed);
  const auto uniform = [&rng] { return static_cast<double>(rng() >> 11) * 0x1.0p-53; };
  int placed = 0, layer = 0;
  double top = 0.0;
  while (placed < o.count) {
    const bool shifted = layer % 2 == 1;
    const int m = shifted ? n - 1 : n;
    const double off = shifted ? a : 0.5 * a;
    const double z = 0.5 * d + 0.1 * d + layer * a;
    for (int iy = 0; iy < m && placed < o.count; ++iy)
      for (int ix = 0; ix < m && placed < o.count; ++ix) {
        const double jx = o.jitter * d * (2.0 * uniform() - 1.0);
        const double jy = o.jitter * d * (2.0 * uniform() - 1.0);
        w.add_sphere(Vec3(off + ix * a + jx, off + iy * a + jy, z), d, o.density);
        ++placed;
      }
    top = z + 0.5 * d;
    ++layer;
  }
  add_box_walls(w, BoxRegion{Vec3::Zero(), Vec3(side, side, top + d)}, o.wall_friction);
  return {n, layer, top};
}

}  // namespace shearzone::sim
