#include "shearzone/sim/scenario.hpp"

#include <random>

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

}  // namespace shearzone::sim
