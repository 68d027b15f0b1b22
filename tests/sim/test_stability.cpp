// Determinism (state hash) and divergence detection: each trigger provoked.
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>

#include <catch2/catch.hpp>

#include "shearzone/sim/scenario.hpp"
#include "shearzone/sim/scene.hpp"
#include "sim/sim_test_util.hpp"

using namespace shearzone;
using namespace shearzone::sim;
using namespace testutil;
using Catch::Matchers::Contains;

namespace {

// 60 beads dropped into a box of five planes (floor and four sides).
World pour(int steps, StepDiagnostics* last = nullptr, int threads = 1, int freeze_sweeps = 16,
           double tolerance = 1e-4, int parallel_min_rows_per_thread = 2000, Solver solver = Solver::alternate) {
  const Options o = solver_options(solver, {.time_step = 5e-4,
                                            .tolerance = tolerance,
                                            .max_iterations = 200,
                                            .freeze_sweeps = freeze_sweeps,
                                            .threads = threads,
                                            .parallel_min_rows_per_thread = parallel_min_rows_per_thread});
  World w(o);
  BoxPour p;  // 60 beads, layers of 4 x 4 at 1.2 d, box 10 d wide, seed 7
  p.diameter = kD;
  p.density = kRho;
  p.half_width = 5.0 * kD;
  add_box_pour(w, p);
  StepDiagnostics d;
  for (int k = 0; k < steps; ++k) d = w.step();
  if (last) *last = d;
  return w;
}

double max_position_difference(const World& a, const World& b) {
  double worst = 0.0;
  for (int k = 0; k < a.body_count(); ++k)
    worst = std::max(worst, (a.position(k) - b.position(k)).norm());
  return worst;
}

}  // namespace

TEST_CASE("The state hash is identical across runs", "[sim]") {
  StepDiagnostics d;
  const World a = pour(400, &d);
  const World b = pour(400);
  INFO("contacts " << d.contacts << " active " << d.active_contacts << " sliding "
                   << d.sliding_contacts << " iterations " << d.iterations << " residual "
                   << d.residual << " max overlap " << d.max_overlap);
  CHECK(a.state_hash() == b.state_hash());
  CHECK(d.active_contacts > 60);
  World c = pour(400);
  c.step();
  CHECK(c.state_hash() != a.state_hash());
}

TEST_CASE("Too few iterations: a tall column sinks and the overlap trigger fires", "[sim]") {
  Options o;
  o.time_step = 2e-3;
  o.max_iterations = 1;
  World w(o);
  w.add_wall(Wall{Vec3::Zero(), Vec3::UnitZ(), 0.5});
  for (int k = 0; k < 60; ++k) w.add_sphere(Vec3(0.0, 0.0, (0.5 + k) * kD), kD, kRho);
  std::string message;
  try {
    for (int k = 0; k < 2000; ++k) w.step();
  } catch (const NoResultError& e) {
    message = e.what();
  }
  INFO(message);
  CHECK_THAT(message, Contains("diverged at step") && Contains("overlap") && Contains("bodies"));
  CHECK(w.iteration_cap_hits() > 0);
}

TEST_CASE("Too large a time step: a pendulum's rope overstretches and the trigger fires", "[sim]") {
  Options o;
  o.time_step = 1e-2;
  World w(o);
  const int a = w.add_sphere(Vec3::Zero(), kD, kRho, BodyKind::kFixed);
  const int b = w.add_sphere(Vec3(5.0 * kD, 0.0, 0.0), kD, kRho);
  w.add_rope(a, b, 5.0 * kD);
  CHECK_THROWS_WITH(
      [&] {
        for (int k = 0; k < 200; ++k) w.step();
      }(),
      Contains("diverged at step") && Contains("rope between bodies 0 and 1"));
}

TEST_CASE("Too large a time step: a fast-turning chain exceeds its angle limit", "[sim]") {
  Options o;
  o.time_step = 5e-3;
  o.gravity = Vec3::Zero();
  o.max_rope_excess = 10.0;  // let the angle trigger speak first
  World w(o);
  const double bond = 1.1 * kD;
  const int a = w.add_sphere(Vec3(-bond, 0.0, 0.0), kD, kRho, BodyKind::kFixed);
  const int b = w.add_sphere(Vec3::Zero(), kD, kRho, BodyKind::kFixed);
  const int c = w.add_sphere(Vec3(bond, 0.0, 0.0), kD, kRho);
  w.add_rope(b, c, bond);
  w.add_angle_limit(a, b, c, deg(30.0));
  w.set_velocity(c, Vec3(0.0, 2.0, 0.0));
  CHECK_THROWS_WITH(
      [&] {
        for (int k = 0; k < 200; ++k) w.step();
      }(),
      Contains("diverged at step") && Contains("turning angle at body 1"));
}

TEST_CASE("A non-finite state stops the run naming the step and the body", "[sim]") {
  Options o;
  o.time_step = 1.0;
  o.gravity = Vec3::Zero();
  World w(o);
  w.add_sphere(Vec3::Zero(), kD, kRho);
  const int b = w.add_sphere(Vec3(1.0, 0.0, 0.0), kD, kRho);
  w.set_velocity(b, Vec3(1e308, 0.0, 0.0));
  CHECK_THROWS_WITH(w.step(), Contains("step 1") && Contains("body 1"));
}

TEST_CASE("Kinematic spheres keep their prescribed motion and push mobile ones", "[sim]") {
  Options o;
  o.time_step = 1e-3;
  o.gravity = Vec3::Zero();
  World w(o);
  const int k = w.add_sphere(Vec3::Zero(), kD, kRho, BodyKind::kKinematic);
  const int m = w.add_sphere(Vec3(1.001 * kD, 0.0, 0.0), kD, kRho);
  w.set_velocity(k, Vec3(0.1, 0.0, 0.0));
  w.set_angular_velocity(k, Vec3(0.0, 0.0, 3.0));
  for (int s = 0; s < 100; ++s) w.step();
  CHECK(w.velocity(k) == Vec3(0.1, 0.0, 0.0));
  CHECK(w.angular_velocity(k) == Vec3(0.0, 0.0, 3.0));
  CHECK(rel_close(w.position(k).x(), 0.01, 1e-12));
  // Pushed ahead (friction with the spinning sphere also moves it sideways), never
  // penetrated: the centre distance stays ≥ d up to round-off, the normal velocity ≥ 0.
  const Vec3 dx = w.position(m) - w.position(k);
  INFO("centre distance " << dx.norm() / kD << " d");
  CHECK(dx.norm() >= kD * (1.0 - 1e-9));
  CHECK((w.velocity(m) - w.velocity(k)).dot(dx.normalized()) >= -1e-9);
  CHECK(w.velocity(m).x() > 0.05);
  CHECK(std::abs(w.velocity(m).y()) > 0.0);
}

TEST_CASE("Bad options and bodies are configuration errors", "[sim]") {
  Options o;
  o.time_step = 0.0;
  CHECK_THROWS_AS(World(o), ConfigError);
  World w{Options{}};
  CHECK_THROWS_AS(w.add_sphere(Vec3::Zero(), -1.0, kRho), ConfigError);
  const int f = w.add_sphere(Vec3::Zero(), kD, kRho, BodyKind::kFixed);
  CHECK_THROWS_AS(w.set_velocity(f, Vec3::UnitX()), ConfigError);
  CHECK_THROWS_AS(w.add_rope(f, 7, kD), ConfigError);
}

TEST_CASE("The slab-parallel sweep is deterministic for a fixed thread count", "[sim]") {
  const Solver solver = GENERATE(Solver::alternate, Solver::forward, Solver::anderson);  // every solver
  const World a = pour(300, nullptr, 2, 16, 1e-4, 2000, solver);
  const World b = pour(300, nullptr, 2, 16, 1e-4, 2000, solver);
  CHECK(a.state_hash() == b.state_hash());
  CHECK(a.iteration_cap_hits() == 0);
  // More slabs than cores works the same way (a thread takes several slabs).
  const World c = pour(300, nullptr, 3, 16, 1e-4, 2000, solver);
  const World c2 = pour(300, nullptr, 3, 16, 1e-4, 2000, solver);
  CHECK(c.state_hash() == c2.state_hash());
  // A different thread count is another Gauss–Seidel order: another solution within the
  // tolerance, not the same bits. The pour is chaotic, so only the outcome is compared:
  // both settle into the same box with the same number of beads resting on the floor
  // within a few.
  const World s = pour(300, nullptr, 1, 16, 1e-4, 2000, solver);
  auto on_floor = [](const World& w) {
    int n = 0;
    for (int k = 0; k < w.body_count(); ++k) n += w.position(k).z() < 0.55 * kD ? 1 : 0;
    return n;
  };
  INFO("beads on the floor: serial " << on_floor(s) << ", 2 slabs " << on_floor(a) << ", 3 slabs "
                                     << on_floor(c));
  CHECK(std::abs(on_floor(s) - on_floor(a)) <= 3);
  CHECK(std::abs(on_floor(s) - on_floor(c)) <= 3);
}

TEST_CASE("The slabs give the same bits on one worker and on T threads", "[sim]") {
  // The pour is small, so by default its slabs run on one thread; forcing the pool
  // (parallel_min_rows_per_thread = 0) must not change a bit, since slabs share no body
  // and the totals are summed in slab order. 150 steps: the lowest layer has landed and
  // the others are colliding (contacts in every slab and across them); 3 threads on a
  // 2-core machine spin on their barriers, so longer runs only cost time.
  const Solver solver = GENERATE(Solver::alternate, Solver::forward, Solver::anderson);  // every solver
  for (int threads : {2, 3}) {
    const World one = pour(150, nullptr, threads, 16, 1e-4, 2000, solver);
    const World pool = pour(150, nullptr, threads, 16, 1e-4, 0, solver);
    INFO(threads << " slabs");
    CHECK(one.state_hash() == pool.state_hash());
  }
}

TEST_CASE("Two threads sweep slab-ordered copies of the bodies and rows and end in the states pinned before "
          "the copies",
          "[sim]") {
  // With threads > 1 the sweeps run on copies of the bodies and rows stored slab by slab
  // (World::to_slab_order), each list's rows in their order, each row's arithmetic
  // unchanged: the same bits as the sweeps on the own order. These hashes were taken
  // from that code (the commit before the copies); a change of them is a change of the
  // engine's arithmetic, not of the layout.
  const Solver solvers[3] = {Solver::alternate, Solver::forward, Solver::anderson};
  const std::uint64_t beads[3] = {0x4c0c5f58849d61a7ULL, 0xdfc8e100251b563eULL, 0x08d00427b818f224ULL};
  for (int s = 0; s < 3; ++s) {
    const World w = pour(150, nullptr, 2, 16, 1e-4, 0, solvers[s]);  // the pool forced
    CHECK(w.state_hash() == beads[s]);
  }
  // The demo's pour of 6-bead chains on two threads: ropes and angle rows in the slabs
  // and across them, 300 steps.
  SceneSpec spec = read_scene(std::filesystem::path(SHEARZONE_DATA_SAMPLES_DIR) / "sim" / "pour_chains.toml");
  spec.sim.threads = 2;
  LoadedScene chains = build_scene(spec, false);
  REQUIRE(chains.world.has_value());
  for (int k = 0; k < 300; ++k) chains.world->step();
  CHECK(chains.world->state_hash() == 0xd522da203c0543a3ULL);
}

TEST_CASE("A checkpointed state continues bit-identically with two threads", "[sim]") {
  const Solver solver = GENERATE(Solver::alternate, Solver::forward, Solver::anderson);  // every solver
  World a = pour(150, nullptr, 2, 16, 1e-4, 0, solver);  // on two threads (the pool forced)
  World b = World::from_state(a.state());
  for (int k = 0; k < 50; ++k) {
    a.step();
    b.step();
  }
  CHECK(a.state_hash() == b.state_hash());
}

TEST_CASE("Freezing skips quiet rows and changes nothing beyond the solver tolerance", "[sim]") {
  // 150 steps of the pour (the lowest layer has landed, the others are still falling
  // and colliding) at a tight tolerance, with and without freezing. Both solve the same
  // steps to 1e-8, so the positions may differ only by what that tolerance allows.
  StepDiagnostics frozen, plain;
  const World a = pour(150, &frozen, 1, 16, 1e-8);
  const World b = pour(150, &plain, 1, 0, 1e-8);
  const double diff = max_position_difference(a, b);
  INFO("max position difference " << diff / kD << " d; last step: " << frozen.row_updates
                                  << " row updates (" << frozen.frozen_skips << " skipped) vs "
                                  << plain.row_updates);
  CHECK(diff < 1e-6 * kD);
  CHECK(frozen.frozen_skips > 0);
  CHECK(plain.frozen_skips == 0);
  CHECK(frozen.row_updates < plain.row_updates);
  // A skipped row that stays open changes nothing, so the two runs can only part where a
  // frozen row would have closed earlier than its re-check; measured: not at all here
  // (identical positions, and the same 4 of 150 steps at the 200-sweep cap for 1e-8).
  CHECK(a.iteration_cap_hits() == b.iteration_cap_hits());
}

TEST_CASE("Anderson acceleration reaches the NLGS solution: the same pour to 1e-8 ends where NLGS ends", "[sim]") {
  // Both solve every step to r <= 1e-8 (the sweep's own change, the same test for both),
  // so the positions may differ only by what that tolerance allows, as with freezing.
  StepDiagnostics aa, nlgs;
  const World a = pour(150, &aa, 1, 16, 1e-8, 2000, Solver::anderson);
  const World b = pour(150, &nlgs, 1, 16, 1e-8, 2000, Solver::forward);
  const double diff = max_position_difference(a, b);
  INFO("max position difference " << diff / kD << " d; last step sweeps: Anderson " << aa.iterations << ", NLGS "
                                  << nlgs.iterations);
  CHECK(diff < 1e-6 * kD);
  CHECK(aa.residual <= 1e-8);
}

TEST_CASE("Orientations follow the angular velocity", "[sim]") {
  Options o;
  o.time_step = 1e-3;
  World w(o);
  const int k = w.add_sphere(Vec3::Zero(), kD, kRho, BodyKind::kKinematic);
  const Vec3 omega = Vec3(1.0, -2.0, 3.0);
  w.set_angular_velocity(k, omega);
  for (int s = 0; s < 1000; ++s) w.step();
  // Constant ω: the orientation after t is the rotation by |ω| t about ω (composition
  // of 1000 exact step rotations about one axis; round-off only).
  const Eigen::Quaterniond expect(Eigen::AngleAxisd(omega.norm() * 1.0, omega.normalized()));
  INFO("angular distance " << w.orientation(k).angularDistance(expect) << " rad");
  CHECK(w.orientation(k).angularDistance(expect) < 1e-10);
  CHECK(std::abs(w.orientation(k).norm() - 1.0) < 1e-14);
}

TEST_CASE("Too large a time step: a body crossing several diameters per step is refused before contact search",
          "[sim]") {
  // The contact search radius grows with speed x step; past 8 diameters every pair within
  // reach becomes a contact row (time and memory ~ n^2), and the step means nothing.
  Options o;
  o.time_step = 1e-3;
  o.gravity = Vec3::Zero();
  World w(o);
  w.add_wall(Wall{Vec3::Zero(), Vec3::UnitZ(), 0.3});
  const int slow = w.add_sphere(Vec3(0.0, 0.0, 2.0 * kD), kD, kRho);
  w.set_velocity(slow, Vec3(1.0 * kD / o.time_step, 0.0, 0.0));  // one diameter per step: fine
  CHECK_NOTHROW(w.step());
  const int fast = w.add_sphere(Vec3(0.0, 0.0, 10.0 * kD), kD, kRho);
  w.set_velocity(fast, Vec3(0.0, 0.0, -20.0 * kD / o.time_step));  // twenty diameters per step
  CHECK_THROWS_AS(w.step(), NoResultError);
  CHECK_THROWS_WITH(w.step(), Contains("time step too large") && Contains("body 1") &&
                                  Contains("lower sim.time_step_s"));
}
