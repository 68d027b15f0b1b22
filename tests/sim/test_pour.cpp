// A poured packing of 2000 beads in a box of planes ([slow]): no divergence, the pile
// settles, and the throughput in row updates per second is reported (one thread).
#include <chrono>
#include <cmath>

#include <catch2/catch.hpp>

#include "shearzone/sim/scenario.hpp"
#include "sim/sim_test_util.hpp"

using namespace shearzone::sim;
using namespace testutil;

TEST_CASE("2000 beads poured into a box settle without divergence (throughput)", "[sim][slow]") {
  World w(Options{.time_step = 5e-4, .friction = 0.2, .tolerance = 1e-4, .max_iterations = 200});
  // Layers of 12 x 12 at 1.02 d in a box 12.5 d wide.
  const BoxPour p{.beads = 2000, .per_row = 12, .diameter = kD, .density = kRho, .half_width = 0.5 * 12.5 * kD,
                  .wall_friction = 0.2, .pitch = 1.02, .jitter = 0.02, .z0 = 0.6, .layer_dz = 1.05, .seed = 11};
  add_box_pour(w, p);
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
  WARN("2000 beads, " << w.steps_done() << " steps of " << w.options().time_step << " s: "
                      << updates / seconds << " row updates/s (whole step), " << w.steps_done() / seconds
                      << " steps/s; last step: " << d.contacts << " contacts, " << d.active_contacts
                      << " active, " << d.iterations << " sweeps, residual " << d.residual
                      << ", KE " << d.kinetic_energy << " J; max overlap " << worst_overlap
                      << " d; cap hits " << w.iteration_cap_hits());
  CHECK(worst_overlap < 0.01);
  CHECK(d.active_contacts > 4000);
}

TEST_CASE("a lattice pour settles into a packing at rest under the solver it will be measured with",
          "[sim]") {
  const LatticePour lp{.count = 60, .diameter = kD, .density = kRho, .seed = 5};
  const PourSettling st{.drop_max_steps = 4000, .relax_min_steps = 20, .relax_max_steps = 2000};
  const SettledPour p = settle_lattice_pour(lp, st, [](Options& o) {
    o.time_step = 1e-3;
    o.tolerance = 1e-4;
    o.max_iterations = 200;
    o.anderson_depth = 3;
  });
  CHECK(p.layout.floor_side == 4);  // ceil(cbrt(60))
  CHECK(p.drop_steps < st.drop_max_steps);
  CHECK(p.drop_kinetic_energy < st.drop_kinetic_energy);
  CHECK(p.relax_steps >= st.relax_min_steps);
  CHECK(p.relax_steps < st.relax_max_steps);
  CHECK(p.relax_kinetic_energy < st.relax_kinetic_energy);
  // The packing carries the relaxation's solver and counts from step 0.
  CHECK(p.state.options.time_step == 1e-3);
  CHECK(p.state.options.anderson_depth == 3);
  CHECK(p.state.options.friction == lp.wall_friction);
  CHECK(p.state.step == 0);
  CHECK(p.state.iteration_cap_hits == 0);
  // At rest on the floor: every bead below the drop's top, none below the floor.
  for (std::size_t b = 0; b < p.state.position.size(); ++b) {
    if (p.state.kind[b] != BodyKind::kMobile) continue;
    CHECK(p.state.position[b].z() > 0.5 * kD * (1 - 1e-3));
    CHECK(p.state.position[b].z() + 0.5 * kD <= p.height * (1 + 1e-9));
  }
}
