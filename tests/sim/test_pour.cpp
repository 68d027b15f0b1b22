// A poured packing of 2000 beads in a box of planes ([slow]): no divergence, the pile
// settles, and the throughput in row updates per second is reported (one thread).
#include <chrono>
#include <cmath>
#include <random>

#include <catch2/catch.hpp>

#include "sim/sim_test_util.hpp"

using namespace shearzone::sim;
using namespace testutil;

TEST_CASE("2000 beads poured into a box settle without divergence (throughput)", "[sim][slow]") {
  Options o;
  o.time_step = 5e-4;
  o.tolerance = 1e-4;
  o.max_iterations = 200;
  o.friction = 0.2;
  World w(o);
  const int side = 12;  // beads per row, box 12.5 d wide
  const double half = 0.5 * 12.5 * kD;
  w.add_wall(Wall{Vec3::Zero(), Vec3::UnitZ(), 0.2});
  w.add_wall(Wall{Vec3(-half, 0, 0), Vec3::UnitX(), 0.2});
  w.add_wall(Wall{Vec3(half, 0, 0), -Vec3::UnitX(), 0.2});
  w.add_wall(Wall{Vec3(0, -half, 0), Vec3::UnitY(), 0.2});
  w.add_wall(Wall{Vec3(0, half, 0), -Vec3::UnitY(), 0.2});
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> jitter(-0.02 * kD, 0.02 * kD);
  int made = 0;
  for (int layer = 0; made < 2000; ++layer)
    for (int iy = 0; iy < side && made < 2000; ++iy)
      for (int ix = 0; ix < side && made < 2000; ++ix, ++made)
        w.add_sphere(Vec3((ix - 0.5 * (side - 1)) * 1.02 * kD + jitter(rng),
                          (iy - 0.5 * (side - 1)) * 1.02 * kD + jitter(rng), (0.6 + 1.05 * layer) * kD),
                     kD, kRho);
  std::int64_t updates = 0;
  double seconds = 0.0, worst_overlap = 0.0;
  StepDiagnostics d;
  for (int k = 0; k < 1200; ++k) {
    const auto t0 = std::chrono::steady_clock::now();
    d = w.step();
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    updates += d.row_updates;
    worst_overlap = std::max(worst_overlap, d.max_overlap);
  }
  WARN("2000 beads, " << w.steps_done() << " steps of " << o.time_step << " s: "
                      << updates / seconds << " row updates/s (whole step), " << w.steps_done() / seconds
                      << " steps/s; last step: " << d.contacts << " contacts, " << d.active_contacts
                      << " active, " << d.iterations << " sweeps, residual " << d.residual
                      << ", KE " << d.kinetic_energy << " J; max overlap " << worst_overlap
                      << " d; cap hits " << w.iteration_cap_hits());
  CHECK(worst_overlap < 0.01);
  CHECK(d.active_contacts > 4000);
}
