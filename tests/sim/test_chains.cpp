// Chain constraints (docs/sim.md, "The model" and "Accuracy"): hanging chain tension,
// rope pendulum, turning-angle limit (bent chain, swinging chain, straight chain guard).
#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include <catch2/catch.hpp>

#include "sim/sim_test_util.hpp"

using namespace shearzone::sim;
using namespace testutil;

namespace {
/// The bound for the hanging-chain tension (relative; docs/sim.md, "Accuracy").
constexpr double kTension = 1e-4;

/// A chain of n beads hanging from a fixed bead, bonds of `bond` (taut), converged to
/// 1e-10 with h = 1e-3 s; its bead indices, the fixed one first.
std::vector<int> hanging_chain(World& w, int n, double bond) {
  std::vector<int> beads{w.add_sphere(Vec3::Zero(), kD, kRho, BodyKind::kFixed)};
  for (int k = 1; k <= n; ++k) beads.push_back(w.add_sphere(Vec3(0.0, 0.0, -k * bond), kD, kRho));
  w.add_chain(beads, bond, std::numbers::pi);
  return beads;
}
Options hanging_chain_options(Solver solver) {
  return solver_options(solver, {.time_step = 1e-3, .tolerance = 1e-10, .max_iterations = 20000});
}
}  // namespace

TEST_CASE("A hanging chain: the rope tension at the top equals the weight below", "[sim]") {
  const Solver solver = GENERATE(Solver::alternate, Solver::forward, Solver::anderson);  // every solver
  const int n = 10;
  const double bond = 1.2 * kD;  // d + l_max with l_max = 0.2 d
  const Options o = hanging_chain_options(solver);
  World w(o);
  const std::vector<int> beads = hanging_chain(w, n, bond);
  StepDiagnostics d;
  for (int k = 0; k < 50; ++k) d = w.step();
  const double m = w.mass(beads[1]), h = o.time_step;
  double worst = 0.0;
  for (int r = 0; r < n; ++r) {
    const double tension = w.rope_impulse(r) / h;
    worst = std::max(worst, std::abs(tension / ((n - r) * m * kG) - 1.0));
  }
  INFO("top tension " << w.rope_impulse(0) / h << " N, weight " << n * m * kG
                      << " N, worst rel err over all ropes " << worst << ", rope excess "
                      << d.max_rope_excess << " d");
  CHECK(rel_close(w.rope_impulse(0) / h, n * m * kG, kTension));
  CHECK(worst <= kTension);
  CHECK(d.max_rope_excess <= 1e-9);
  CHECK(d.active_ropes == n);
  CHECK(w.iteration_cap_hits() == 0);
}

TEST_CASE("A rope pendulum keeps its length and its period", "[sim]") {
  const Solver solver = GENERATE(Solver::alternate, Solver::forward, Solver::anderson);  // every solver
  // Small amplitude: period 2π√(L/g)(1 + θ0²/16). Length: with θ = 1 the new position
  // lies on the tangent of the circle, off by (v h)²/(2L) ≤ g h² θ0²... per step before
  // the next step's C/h term removes it: the bound is that chord error plus the solver's.
  const double L = 5.0 * kD, h = 1e-4, theta0 = deg(5.0);
  Options o = solver_options(solver, {.time_step = h, .tolerance = 1e-10});
  World w(o);
  const int a = w.add_sphere(Vec3::Zero(), kD, kRho, BodyKind::kFixed);
  const int b = w.add_sphere(L * Vec3(std::sin(theta0), 0.0, -std::cos(theta0)), kD, kRho);
  w.add_rope(a, b, L);
  const double v_max = std::sqrt(2.0 * kG * L * (1.0 - std::cos(theta0)));
  const double chord = v_max * v_max * h * h / (2.0 * L);
  const double bound = 1.01 * chord + 1e-12;
  double worst_long = 0.0, worst_short = 0.0, worst_spin = 0.0;
  std::vector<double> crossings;
  double x_prev = w.position(b).x();
  const double period = 2.0 * std::numbers::pi * std::sqrt(L / kG) * (1.0 + theta0 * theta0 / 16.0);
  while (w.time() < 3.2 * period) {
    w.step();
    const double dist = w.position(b).norm();
    worst_long = std::max(worst_long, dist - L);
    worst_short = std::max(worst_short, L - dist);
    worst_spin = std::max(worst_spin, w.angular_velocity(b).norm());
    const double x = w.position(b).x();
    if (x_prev > 0.0 && x <= 0.0) crossings.push_back(w.time() - h * x / (x - x_prev));
    x_prev = x;
  }
  REQUIRE(crossings.size() >= 3);
  const double measured = (crossings.back() - crossings.front()) / static_cast<double>(crossings.size() - 1);
  INFO("longest " << worst_long << " m, shortest " << worst_short << " m, bound " << bound
                  << " m; period " << measured << " s vs " << period << " s, rel err "
                  << std::abs(measured / period - 1.0));
  CHECK(worst_long <= bound);
  CHECK(worst_short <= bound);
  CHECK(worst_spin == 0.0);
  // Implicit Euler: period error O((ω h)²) ≈ 2e-6; the θ0⁴ term of the period ≈ 1e-6.
  CHECK(rel_close(measured, period, 1e-4));
}

TEST_CASE("The turning-angle limit holds on a bent and a swinging chain", "[sim]") {
  const Solver solver = GENERATE(Solver::alternate, Solver::forward, Solver::anderson);  // every solver
  const double bond = 1.1 * kD, theta_max = deg(30.0);
  SECTION("a chain bent beyond the limit is straightened to it in one step") {
    Options o = solver_options(solver, {.time_step = 1e-3, .gravity = Vec3::Zero(), .tolerance = 1e-12});
    World w(o);
    const double bent = deg(45.0);
    std::vector<int> beads{w.add_sphere(Vec3(-bond, 0.0, 0.0), kD, kRho),
                           w.add_sphere(Vec3::Zero(), kD, kRho),
                           w.add_sphere(bond * Vec3(std::cos(bent), std::sin(bent), 0.0), kD, kRho)};
    w.add_chain(beads, bond, theta_max);
    const StepDiagnostics d = w.step();
    INFO("angle excess after one step " << d.max_angle_excess << " rad");
    // The row is linear in the positions: a 15° (0.26 rad) correction in one step leaves a
    // second-order remainder (measured 0.031 rad, 12 %); each further step squares the
    // relative remainder (Newton-like), so two more steps bring it to round-off.
    CHECK(d.max_angle_excess < 0.05);
    const StepDiagnostics d2 = w.step();
    const StepDiagnostics d3 = w.step();
    INFO("after two steps " << d2.max_angle_excess << " rad, after three " << d3.max_angle_excess);
    CHECK(d2.max_angle_excess < 1e-3);
    CHECK(d3.max_angle_excess < 1e-9);
  }
  SECTION("a chain swinging down from two fixed beads never exceeds the limit") {
    const double h = 1e-4;
    Options o = solver_options(solver, {.time_step = h, .tolerance = 1e-8, .max_iterations = 5000});
    World w(o);
    std::vector<int> beads{w.add_sphere(Vec3(-bond, 0.0, 0.0), kD, kRho, BodyKind::kFixed),
                           w.add_sphere(Vec3::Zero(), kD, kRho, BodyKind::kFixed)};
    for (int k = 1; k <= 6; ++k) beads.push_back(w.add_sphere(Vec3(k * bond, 0.0, 0.0), kD, kRho));
    w.add_chain(beads, bond, theta_max);
    double worst = 0.0, rate = 0.0;
    int active = 0;
    for (int k = 0; k < 3000; ++k) {
      const StepDiagnostics d = w.step();
      worst = std::max(worst, d.max_angle_excess);
      active = std::max(active, d.active_angles);
      for (std::size_t i = 0; i + 1 < beads.size(); ++i)
        rate = std::max(rate, (w.velocity(beads[i + 1]) - w.velocity(beads[i])).norm() / bond);
    }
    // Bound: the row is exact to first order in the positions; the second-order remainder
    // per step is ≈ ½ Σ|Δx|² |∂²c| ≲ (ω h)² in cos θ over three bodies, i.e.
    // ≈ 2 (ω h)² / sin θ_max in θ, with ω the largest bond rotation rate of the run.
    const double bound = 2.0 * (rate * h) * (rate * h) / std::sin(theta_max);
    INFO("max angle excess " << worst << " rad, bound " << bound << " (bond rate " << rate
                             << " rad/s), max active angle rows " << active << ", cap hits "
                             << w.iteration_cap_hits());
    CHECK(worst <= bound);
    CHECK(active >= 3);
    CHECK(w.iteration_cap_hits() == 0);
  }
}

TEST_CASE("A straight chain falls freely: angle rows stay inactive (W_a guard)", "[sim]") {
  const Solver solver = GENERATE(Solver::alternate, Solver::forward, Solver::anderson);  // every solver
  Options o = solver_options(solver, {.time_step = 1e-3});
  World w(o);
  std::vector<int> beads;
  for (int k = 0; k < 5; ++k) beads.push_back(w.add_sphere(Vec3(1.1 * kD * k, 0.0, 0.0), kD, kRho));
  w.add_chain(beads, 1.1 * kD, deg(30.0));
  for (int k = 0; k < 100; ++k) {
    const StepDiagnostics d = w.step();
    REQUIRE(d.active_angles == 0);
    REQUIRE(d.max_angle_excess == 0.0);
  }
  for (int b : beads) CHECK(rel_close(w.velocity(b).z(), -kG * w.time(), 1e-12));
  for (int a = 0; a < w.angle_count(); ++a) CHECK(w.angle_impulse(a) == 0.0);
}

TEST_CASE("A hanging chain continued at half the time step keeps its tensions from the first step (at_time_step)",
          "[sim]") {
  const int n = 10;
  const Options o = hanging_chain_options(Solver::forward);
  World w(o);
  const std::vector<int> beads = hanging_chain(w, n, 1.2 * kD);
  for (int k = 0; k < 50; ++k) (void)w.step();
  const WorldState before = w.state();
  WorldState s = at_time_step(before, 0.5 * o.time_step);
  REQUIRE(s.options.time_step == 0.5 * o.time_step);
  for (std::size_t r = 0; r < s.ropes.size(); ++r) CHECK(s.ropes[r].impulse == 0.5 * before.ropes[r].impulse);
  // Two sweeps only: the warm start must already be the tension (a doubled force would
  // need many sweeps of the ten-bead chain to come back).
  s.options.max_iterations = 2;
  World half = World::from_state(s);
  (void)half.step();
  const double m = half.mass(beads[1]);
  double worst = 0.0;
  for (int r = 0; r < n; ++r)
    worst = std::max(worst, std::abs(half.rope_impulse(r) / s.options.time_step / ((n - r) * m * kG) - 1.0));
  INFO("worst relative tension error after the restart: " << worst);
  CHECK(worst < 1e-3);  // the hanging chain's tension bound is kTension = 1e-4 at convergence
}
