// The rigid rotor (the vane): exact rotated positions, the motor torque and its sign,
// a checkpoint that keeps the drive, and a new drive for an amplitude branch.
#include <cmath>
#include <numbers>
#include <vector>

#include <catch2/catch.hpp>

#include "shearzone/core/error.hpp"
#include "shearzone/sim/sim_io.hpp"
#include "sim/sim_test_util.hpp"
#include "support/temp_dir.hpp"

using namespace shearzone;
using namespace shearzone::sim;
using namespace testutil;

namespace {

/// A four-blade vane of 3 touching beads per blade about the z axis through (cx, cy),
/// blade 0 along +x, beads at radii 1.5 d, 2.5 d, 3.5 d; returns the bead indices.
std::vector<int> add_vane(World& w, double cx, double cy, double z) {
  std::vector<int> beads;
  for (int blade = 0; blade < 4; ++blade) {
    const double a = blade * std::numbers::pi / 2;
    for (int k = 0; k < 3; ++k) {
      const double r = (1.5 + k) * kD;
      beads.push_back(w.add_sphere(Vec3(cx + r * std::cos(a), cy + r * std::sin(a), z), kD, kRho,
                                   BodyKind::kKinematic));
    }
  }
  return beads;
}

}  // namespace

TEST_CASE("a rotor's beads sit at the exact rotated positions and never move radially", "[sim][rotor]") {
  Options o;
  o.time_step = 1e-3;
  o.gravity = Vec3::Zero();
  World w(o);
  const double cx = 0.013, cy = -0.007, z = 0.02;
  const auto beads = add_vane(w, cx, cy, z);
  std::vector<Vec3> x0;
  for (int b : beads) x0.push_back(w.position(b));
  const double phi0 = 0.3, f = 1.0;
  const int r = w.add_rotor(beads, Vec3(cx, cy, 0), Vec3(0, 0, 2), phi0, f);
  CHECK(w.rotor(r).axis == Vec3::UnitZ());
  double worst_pos = 0, worst_radial = 0, worst_z = 0;
  for (int step = 1; step <= 10000; ++step) {
    w.step();
    const double phi = phi0 * std::sin(2 * std::numbers::pi * f * step * o.time_step);
    REQUIRE(w.rotor_angle(r) == Approx(phi).margin(1e-13));
    for (std::size_t k = 0; k < beads.size(); ++k) {
      const Vec3 d0 = x0[k] - Vec3(cx, cy, z);
      const Vec3 want = Vec3(cx, cy, z) + Vec3(std::cos(phi) * d0.x() - std::sin(phi) * d0.y(),
                                               std::sin(phi) * d0.x() + std::cos(phi) * d0.y(), 0);
      const Vec3& x = w.position(beads[k]);
      worst_pos = std::max(worst_pos, (x - want).norm() / d0.norm());
      worst_radial = std::max(worst_radial, std::abs(std::hypot(x.x() - cx, x.y() - cy) - d0.norm()) / d0.norm());
      worst_z = std::max(worst_z, std::abs(x.z() - z));
    }
  }
  INFO("position " << worst_pos << ", radius " << worst_radial);
  CHECK(worst_pos < 1e-12);     // the bound, over 1e4 steps
  CHECK(worst_radial < 1e-12);
  CHECK(worst_z == 0.0);
  // The velocity the solve sees: the chord of the step, Ω × r to O(h²).
  const double t = w.time(), h = o.time_step;
  const double omega = phi0 * 2 * std::numbers::pi * f * std::cos(2 * std::numbers::pi * f * (t - 0.5 * h));
  const Vec3 d = w.position(beads[2]) - Vec3(cx, cy, z);
  CHECK(w.velocity(beads[2]).norm() == Approx(std::abs(omega) * d.norm()).epsilon(1e-5));
}

TEST_CASE("the motor torque of a vane holding a bead against gravity is r m g, positive towards +phi",
          "[sim][rotor]") {
  // A bead rests on the outer bead of blade 0 (at x = r) under gravity along -y: the bead
  // pushes the blade towards -phi (clockwise), so the motor holds it with +r m g.
  Options o;
  o.time_step = 1e-3;
  o.gravity = Vec3(0, -kG, 0);
  o.friction = 0.0;
  o.tolerance = 1e-12;
  World w(o);
  const double r = 3.5 * kD;
  const int vb = w.add_sphere(Vec3(r, 0, 0), kD, kRho, BodyKind::kKinematic);
  const int bead = w.add_sphere(Vec3(r, kD, 0), kD, kRho);
  const int rot = w.add_rotor(std::vector<int>{vb}, Vec3::Zero(), Vec3::UnitZ(), 0.0, 0.0);
  CHECK(w.rotor_torque(rot) == 0.0);
  for (int k = 0; k < 20; ++k) w.step();
  const double m = w.mass(bead);
  // Contact point at (r, d/2): torque of the bead on the vane (r, d/2) x (0, -m g) = -r m g.
  CHECK(w.rotor_torque(rot) == Approx(r * m * kG).epsilon(1e-6));
  CHECK(w.rotor_torque(rot) > 0);
  // Mirrored (gravity along +y): the motor pulls the other way.
  Options o2 = o;
  o2.gravity = Vec3(0, kG, 0);
  World w2(o2);
  const int vb2 = w2.add_sphere(Vec3(r, 0, 0), kD, kRho, BodyKind::kKinematic);
  w2.add_sphere(Vec3(r, -kD, 0), kD, kRho);
  const int rot2 = w2.add_rotor(std::vector<int>{vb2}, Vec3::Zero(), Vec3::UnitZ(), 0.0, 0.0);
  for (int k = 0; k < 20; ++k) w2.step();
  CHECK(w2.rotor_torque(rot2) == Approx(-r * m * kG).epsilon(1e-6));
}

TEST_CASE("a checkpoint keeps the rotor, a branch with a new drive starts from the checkpoint's place",
          "[sim][rotor]") {
  shearzone::testing::TempDir dir("rotor_ckpt");
  Options o;
  o.time_step = 1e-3;
  o.friction = 0.3;
  World a(o);
  a.add_wall(Wall{Vec3::Zero(), Vec3::UnitZ(), 0.3});
  const auto beads = add_vane(a, 0, 0, 0.5 * kD);
  // A few mobile beads between the blades.
  for (int k = 0; k < 6; ++k) {
    const double ang = std::numbers::pi / 4 + k * std::numbers::pi / 2;
    a.add_sphere(Vec3(2.5 * kD * std::cos(ang), 2.5 * kD * std::sin(ang), (0.5 + 1.05 * (k / 4)) * kD), kD, kRho);
  }
  a.add_rotor(beads, Vec3::Zero(), Vec3::UnitZ(), 0.2, 2.0);
  for (int k = 0; k < 200; ++k) a.step();
  write_checkpoint(dir / "c.h5", a, {{"tool", "test"}});
  World b = World::from_state(read_checkpoint(dir / "c.h5"));
  REQUIRE(b.rotor_count() == 1);
  CHECK(b.state_hash() == a.state_hash());
  CHECK(b.rotor_angle(0) == a.rotor_angle(0));
  for (int k = 0; k < 300; ++k) {
    a.step();
    b.step();
  }
  CHECK(a.state_hash() == b.state_hash());
  CHECK(a.rotor_torque(0) == b.rotor_torque(0));
  // A branch run straight through (the same world goes on with a new drive) and the same
  // branch from the checkpoint: the same state.
  {
    World straight = World::from_state(read_checkpoint(dir / "c.h5"));
    World restarted = World::from_state(read_checkpoint(dir / "c.h5"));
    // `straight` stands for the run that never stopped: its state is the checkpoint's bits.
    straight.set_rotor_drive(0, 0.3, 0.5, 0.0, straight.time());
    restarted.set_rotor_drive(0, 0.3, 0.5, 0.0, restarted.time());
    for (int k = 0; k < 200; ++k) {
      straight.step();
      restarted.step();
    }
    CHECK(straight.state_hash() == restarted.state_hash());
  }
  // A branch: a new drive from now on (time origin now, so phi = 0 at the start).
  World c = World::from_state(read_checkpoint(dir / "c.h5"));
  const double t0 = c.time();
  c.set_rotor_drive(0, 0.05, 0.5, 0.0, t0);
  CHECK(c.rotor_angle(0) == 0.0);
  c.step();
  CHECK(c.rotor_angle(0) == Approx(0.05 * std::sin(2 * std::numbers::pi * 0.5 * 1e-3)).epsilon(1e-9));
  CHECK_THROWS_AS(c.set_rotor_drive(0, 0.1, -1.0, 0.0, 0.0), ConfigError);
  // Only kinematic beads can be in a rotor, each in one.
  CHECK_THROWS_AS(a.add_rotor(std::vector<int>{beads.back() + 1}, Vec3::Zero(), Vec3::UnitZ(), 0.1, 1.0),
                  ConfigError);
  CHECK_THROWS_AS(a.add_rotor(std::vector<int>{beads[0]}, Vec3::Zero(), Vec3::UnitZ(), 0.1, 1.0), ConfigError);
}
