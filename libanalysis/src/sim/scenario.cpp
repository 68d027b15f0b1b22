#include "shearzone/sim/scenario.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <utility>

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

namespace {

/// Translational ½ m v² per bead of the pour over m g d.
double kinetic_energy_per_mgd(const World& w, const LatticePour& pour) {
  const double d = pour.diameter;
  const double mgd = pour.density * std::numbers::pi * d * d * d / 6.0 * 9.81 * d;
  double ke = 0.0;
  for (int b = 0; b < w.body_count(); ++b) ke += 0.5 * w.mass(b) * w.velocity(b).squaredNorm();
  return ke / pour.count / mgd;
}

}  // namespace

SettledPour settle_lattice_pour(const LatticePour& pour, const PourSettling& st,
                                const std::function<void(Options&)>& relax_solver) {
  const double d = pour.diameter;
  Options o;
  o.time_step = st.drop_time_step;
  o.friction = pour.wall_friction;
  o.tolerance = st.drop_tolerance;
  o.max_iterations = st.drop_max_iterations;
  World w(o);
  SettledPour p;
  p.layout = add_lattice_pour(w, pour);
  // At least the free fall of the gaps the lattice leaves in its column, plus one d.
  const double drop = p.layout.layers * (pour.pitch - 1.0) * d + d;
  const auto min_steps =
      static_cast<std::int64_t>(std::ceil(2.0 * std::sqrt(2.0 * drop / 9.81) / st.drop_time_step));
  for (std::int64_t s = 1; s <= st.drop_max_steps; ++s) {
    w.step();
    p.drop_steps = s;
    p.drop_kinetic_energy = kinetic_energy_per_mgd(w, pour);
    if (s >= min_steps && p.drop_kinetic_energy < st.drop_kinetic_energy) break;
  }
  for (int b = 0; b < w.body_count(); ++b) p.height = std::max(p.height, w.position(b).z() + 0.5 * d);
  WorldState dropped = w.state();
  Options relax = dropped.options;
  relax_solver(relax);
  dropped = at_time_step(std::move(dropped), relax.time_step);
  dropped.options = relax;
  dropped.step = 0;  // the relaxation counts its own steps
  dropped.iteration_cap_hits = 0;
  World r = World::from_state(dropped);
  for (std::int64_t k = 1; k <= st.relax_max_steps; ++k) {
    const StepDiagnostics sd = r.step();
    p.relax_steps = k;
    p.relax_kinetic_energy = kinetic_energy_per_mgd(r, pour);
    if (k >= st.relax_min_steps && !sd.hit_iteration_cap && p.relax_kinetic_energy < st.relax_kinetic_energy) break;
  }
  p.state = r.state();
  p.state.step = 0;
  p.state.iteration_cap_hits = 0;
  return p;
}

}  // namespace shearzone::sim
