// Analytic validations of the contact solve (docs/sim.md, "Accuracy"): a sphere on an
// incline (rolling and sliding), a sphere launched on a plane, columns at rest (support
// impulse from all fixed bodies = M g h), a bead at rest in a pocket of fixed beads.
#include <cmath>
#include <numbers>

#include <catch2/catch.hpp>

#include "sim/sim_test_util.hpp"

using namespace shearzone::sim;
using namespace testutil;

namespace {
/// The bound for the incline accelerations (relative; docs/sim.md, "Accuracy").
constexpr double kIncline = 1e-3;
/// The bound for the support impulse of a column at rest (relative; docs/sim.md).
constexpr double kColumn = 1e-4;
/// The bound for the bead in a pocket: displacement / d over 1e4 steps (docs/sim.md).
constexpr double kPocket = 1e-6;

struct InclineResult {
  double a, alpha_dot, v_slip;
};

// Plane z = 0 with friction μ, gravity tilted by α (same as a plane inclined at α).
InclineResult incline(double alpha, double mu, Solver solver) {
  const Options o = solver_options(
      solver, {.time_step = 1e-4, .gravity = kG * Vec3(std::sin(alpha), 0.0, -std::cos(alpha)), .tolerance = 1e-12});
  World w(o);
  w.add_wall(Wall{Vec3::Zero(), Vec3::UnitZ(), mu});
  const int b = w.add_sphere(Vec3(0.0, 0.0, 0.5 * kD), kD, kRho);
  const int steps = 2000;
  for (int k = 0; k < steps; ++k) w.step();
  const double t = w.time();
  const Vec3 v = w.velocity(b), om = w.angular_velocity(b);
  // Contact-point slip: v + ω × (−R e_z).
  const double slip = (v + om.cross(Vec3(0.0, 0.0, -0.5 * kD))).x();
  return {v.x() / t, om.y() / t, slip};
}
}  // namespace

TEST_CASE("A sphere on an incline with tan a <= 3.5 mu rolls without slip, a = 5/7 g sin a",
          "[sim]") {
  const Solver solver = GENERATE(Solver::alternate, Solver::forward, Solver::anderson);  // every solver
  for (const auto& [alpha_deg, mu] : {std::pair{20.0, 0.5}, std::pair{30.0, 0.2}, std::pair{40.0, 0.24}}) {
    const double alpha = deg(alpha_deg);
    REQUIRE(std::tan(alpha) <= 3.5 * mu);
    const InclineResult r = incline(alpha, mu, solver);
    const double expected = 5.0 / 7.0 * kG * std::sin(alpha);
    INFO("alpha " << alpha_deg << " mu " << mu << " a " << r.a << " expected " << expected
                  << " rel err " << std::abs(r.a / expected - 1.0));
    CHECK(rel_close(r.a, expected, kIncline));
    CHECK(rel_close(r.alpha_dot, expected / (0.5 * kD), kIncline));
    CHECK(std::abs(r.v_slip) <= 1e-9 * expected);
  }
}

TEST_CASE("A sphere on an incline with tan a > 3.5 mu slides, a = g(sin a - mu cos a)", "[sim]") {
  const Solver solver = GENERATE(Solver::alternate, Solver::forward, Solver::anderson);  // every solver
  for (const auto& [alpha_deg, mu] : {std::pair{40.0, 0.1}, std::pair{60.0, 0.3}, std::pair{30.0, 0.0}}) {
    const double alpha = deg(alpha_deg);
    REQUIRE(std::tan(alpha) > 3.5 * mu);
    const InclineResult r = incline(alpha, mu, solver);
    const double a = kG * (std::sin(alpha) - mu * std::cos(alpha));
    const double alpha_dot = 5.0 * mu * kG * std::cos(alpha) / kD;  // 5 μ g cos α /(2R)
    INFO("alpha " << alpha_deg << " mu " << mu << " a " << r.a << " expected " << a
                  << " rel err " << std::abs(r.a / a - 1.0) << " angular " << r.alpha_dot
                  << " expected " << alpha_dot);
    CHECK(rel_close(r.a, a, kIncline));
    if (mu > 0.0)
      CHECK(rel_close(r.alpha_dot, alpha_dot, kIncline));
    else
      CHECK(r.alpha_dot == 0.0);
    CHECK(r.v_slip > 0.0);
  }
}

TEST_CASE("A sphere launched on a plane rolls at 5/7 v0 from t* = 2 v0 /(7 mu g)", "[sim]") {
  const Solver solver = GENERATE(Solver::alternate, Solver::forward, Solver::anderson);  // every solver
  const double v0 = 0.5, mu = 0.3, h = 1e-5;
  Options o = solver_options(solver, {.time_step = h, .tolerance = 1e-12});
  World w(o);
  w.add_wall(Wall{Vec3::Zero(), Vec3::UnitZ(), mu});
  const int b = w.add_sphere(Vec3(0.0, 0.0, 0.5 * kD), kD, kRho);
  w.set_velocity(b, Vec3(v0, 0.0, 0.0));
  const double t_star = 2.0 * v0 / (7.0 * mu * kG);
  double t_stick = -1.0;
  double worst_slide = 0.0;
  while (w.time() < 2.0 * t_star) {
    w.step();
    const auto c = w.contacts();
    REQUIRE(c.size() == 1);
    if (c[0].status == ContactStatus::kSliding) {
      // Sliding phase: v = v0 − μ g t exactly (the discrete scheme is exact here).
      worst_slide = std::max(worst_slide, std::abs(w.velocity(b).x() - (v0 - mu * kG * w.time())));
    } else if (t_stick < 0.0) {
      t_stick = w.time();
    }
  }
  INFO("t_stick " << t_stick << " t* " << t_star << " v " << w.velocity(b).x());
  CHECK(worst_slide <= 1e-12);
  CHECK(std::abs(t_stick - t_star) <= h);
  CHECK(rel_close(w.velocity(b).x(), 5.0 / 7.0 * v0, 1e-10));
}

TEST_CASE("A column at rest: the support impulse per step equals M g h", "[sim]") {
  const Solver solver = GENERATE(Solver::alternate, Solver::forward, Solver::anderson);  // every solver
  const int n_beads = 12;
  for (const bool pocket : {false, true}) {
    Options o = solver_options(solver, {.time_step = 1e-3, .tolerance = 1e-8, .max_iterations = 20000});
    World w(o);
    double z0 = 0.5 * kD;
    if (pocket)
      z0 = add_pocket(w);
    else
      w.add_wall(Wall{Vec3::Zero(), Vec3::UnitZ(), 0.5});
    double mass = 0.0;
    for (int k = 0; k < n_beads; ++k) {
      const int b = w.add_sphere(Vec3(0.0, 0.0, z0 + k * kD), kD, kRho);
      mass += w.mass(b);
    }
    StepDiagnostics d;
    for (int k = 0; k < 20; ++k) d = w.step();
    const double expected = mass * kG * o.time_step;
    const double got = vertical_impulse_from_supports(w);
    INFO((pocket ? "pocket" : "plane") << ": support impulse " << got << " M g h " << expected
                                       << " rel err " << std::abs(got / expected - 1.0)
                                       << " iterations " << d.iterations << " residual " << d.residual);
    CHECK(rel_close(got, expected, kColumn));
    CHECK(d.max_overlap <= 1e-6);
    CHECK(d.kinetic_energy <= 1e-12 * mass * kG * kD);
    CHECK(w.iteration_cap_hits() == 0);
  }
}

TEST_CASE("A bead in a pocket of fixed beads stays put over 1e4 steps", "[sim]") {
  const Solver solver = GENERATE(Solver::alternate, Solver::forward, Solver::anderson);  // every solver
  Options o = solver_options(solver, {.time_step = 1e-3, .friction = 0.3, .tolerance = 1e-6});
  World w(o);
  const double z = add_pocket(w);
  const Vec3 start(0.0, 0.0, z);
  const int b = w.add_sphere(start, kD, kRho);
  double worst = 0.0;
  int max_iter = 0;
  for (int k = 0; k < 10000; ++k) {
    const StepDiagnostics d = w.step();
    max_iter = std::max(max_iter, d.iterations);
    worst = std::max(worst, (w.position(b) - start).norm() / kD);
  }
  INFO("max displacement " << worst << " d, max iterations " << max_iter);
  CHECK(worst < kPocket);
  CHECK(w.iteration_cap_hits() == 0);
}
