// The periodic sector (Options::sectors): one wedge of a k-fold symmetric system moves as
// the whole system does, across its seams (contacts, ropes, angle rows, wrapped beads),
// with the vane's torque one k-th of the whole; and it restarts bit-identically.
#include <catch2/catch.hpp>

#include <cmath>
#include <fstream>
#include <numbers>
#include <vector>

#include "shearzone/core/error.hpp"
#include "shearzone/sim/builder.hpp"
#include "shearzone/sim/world.hpp"
#include "shearzone/sim/scene.hpp"
#include "shearzone/sim/sim_io.hpp"
#include "shearzone/sim/surface.hpp"
#include "sim_test_util.hpp"
#include "support/temp_dir.hpp"

using shearzone::sim::BodyKind;
using shearzone::sim::Options;
using shearzone::sim::Vec3;
using shearzone::sim::Wall;
using shearzone::sim::World;
using shearzone::sim::WorldState;
using shearzone::sim::read_checkpoint;
using shearzone::sim::write_checkpoint;
using shearzone::testing::TempDir;
using testutil::kD;
using testutil::kRho;

namespace {

constexpr int kSectors = 4;
constexpr double kStart = -std::numbers::pi / 4.0;  // the wedge [-45°, 45°) holds blade 0

Vec3 turn(const Vec3& x, int m) {  // rotation by m quarter turns about z (exact)
  Vec3 p = x;
  for (int k = 0; k < ((m % 4) + 4) % 4; ++k) p = Vec3(-p.y(), p.x(), p.z());
  return p;
}

Vec3 polar(double r, double deg, double z) {
  const double a = testutil::deg(deg);
  return {r * std::cos(a), r * std::sin(a), z};
}

/// Quarter turns that bring x into the wedge [−45°, 45°).
int wedge_turns(const Vec3& x) {
  for (int m = 0; m < 4; ++m) {
    const Vec3 p = turn(x, m);
    const double a = std::atan2(p.y(), p.x());
    if (a >= kStart && a < kStart + std::numbers::pi / 2) return m;
  }
  return 0;
}

/// One sector's content: mobile beads sliding round the cup on the floor (some across a
/// seam), a bead by the hub, a falling chain across the upper seam; a rotor (hub bead on
/// the axis and a blade at 0°). `copies` = 4 builds the whole system, 1 the sector.
struct Scene {
  std::vector<int> beads;  // the mobile beads of copy 0
  int rotor = -1;
};

Scene build(World& w, int copies) {
  Scene s;
  w.add_wall(Wall{Vec3::Zero(), Vec3::UnitZ(), 0.3});
  const double z0 = 0.5 * kD, omega = 1.0;  // rad/s about z
  std::vector<Vec3> loose = {polar(5 * kD, 40, z0), polar(5 * kD, 28, z0), polar(5 * kD, -38, z0),
                             polar(6.2 * kD, 44, z0), polar(3.0 * kD, 20, z0), polar(1.0 * kD, 30, z0),
                             polar(6.2 * kD, -44, 1.6 * kD)};
  std::vector<Vec3> chain = {polar(8 * kD, 34, 2 * kD), polar(8 * kD, 41.5, 2 * kD), polar(8 * kD, 49, 2 * kD),
                             polar(8 * kD, 56.5, 2 * kD)};
  std::vector<int> rotor;
  for (int m = 0; m < copies; ++m) {
    if (m == 0) rotor.push_back(w.add_sphere(Vec3(0, 0, z0), kD, kRho, BodyKind::kKinematic));  // the hub
    for (int k = 2; k <= 3; ++k) rotor.push_back(w.add_sphere(turn(Vec3(k * kD, 0, z0), m), kD, kRho, BodyKind::kKinematic));
  }
  for (int m = 0; m < copies; ++m) {
    // A bead of copy m at R^m x, moving with the rigid rotation; in the sector, the
    // image of that bead inside the wedge.
    auto add = [&](const Vec3& x) {
      const int turns = copies == 1 ? wedge_turns(x) : m;
      const int b = w.add_sphere(turn(x, turns), kD, kRho);
      w.set_velocity(b, turn(Vec3(-omega * x.y(), omega * x.x(), 0.0), turns));
      if (m == 0) s.beads.push_back(b);
      return b;
    };
    for (const Vec3& x : loose) add(x);
    std::vector<int> ids;
    for (const Vec3& x : chain) ids.push_back(add(x));
    w.add_chain(ids, 1.1 * kD, testutil::deg(40.0));
  }
  s.rotor = w.add_rotor(rotor, Vec3::Zero(), Vec3::UnitZ(), 0.3, 2.0);
  return s;
}

Options tight() {
  Options o;
  o.friction = 0.2;
  o.tolerance = 1e-12;
  o.max_iterations = 20000;
  o.freeze_sweeps = 0;
  return o;
}

Options sector(Options o) {
  o.sectors = kSectors;
  o.sector_start = kStart;
  return o;
}

/// The copy-0 bead b of the whole system, seen in the sector (its image in the wedge).
Vec3 in_wedge(const Vec3& x) { return turn(x, wedge_turns(x)); }

}  // namespace

TEST_CASE("A periodic quarter moves as the whole cup across its seams", "[sim][sector]") {
  const auto solver = GENERATE(testutil::Solver::alternate, testutil::Solver::forward, testutil::Solver::anderson);
  Options o = tight();
  testutil::set_solver(o, solver);
  World whole(o), quarter(sector(o));
  const Scene sw = build(whole, 4), sq = build(quarter, 1);
  // Beads 0 (40°), 3 (44°) and the chain's last two start beyond or near the upper seam.
  REQUIRE(sq.beads.size() == sw.beads.size());
  bool seam_row = false, seam_rope = false;
  int wraps = 0;
  std::vector<Vec3> last(sq.beads.size());
  for (std::size_t k = 0; k < sq.beads.size(); ++k) last[k] = quarter.position(sq.beads[k]);
  for (int step = 0; step < 400; ++step) {
    whole.step();
    quarter.step();
    for (const auto& c : quarter.contacts()) seam_row = seam_row || (c.image == 1 && c.normal_impulse > 0.0);
    for (const auto& r : quarter.state().ropes) seam_rope = seam_rope || r.image != 0;
    for (std::size_t k = 0; k < sq.beads.size(); ++k) {
      const Vec3 x = quarter.position(sq.beads[k]);
      if ((x - last[k]).norm() > kD) ++wraps;  // moved to its image across the wedge
      last[k] = x;
    }
    // Torque: the sector's rotor carries one blade of four (the hub is shared).
    CHECK(std::abs(4.0 * quarter.rotor_torque(sq.rotor) - whole.rotor_torque(sw.rotor)) <=
          1e-6 * std::abs(whole.rotor_torque(sw.rotor)) + 1e-12);
  }
  // The test crossed the seams: a loaded seam row, a rope across a seam, wrapped beads.
  CHECK(seam_row);
  CHECK(seam_rope);
  CHECK(wraps > 0);
  // Tolerance: both runs converge every step to 1e-12; the two Gauss-Seidel orders then
  // agree to ~1e-10 d per step, 400 steps of sliding and colliding beads.
  constexpr double kAgree = 1e-7 * kD;
  for (std::size_t k = 0; k < sq.beads.size(); ++k) {
    INFO("bead " << k);
    CHECK((quarter.position(sq.beads[k]) - in_wedge(whole.position(sw.beads[k]))).norm() <= kAgree);
    CHECK(shearzone::sim::sector_contains(quarter.options(), quarter.position(sq.beads[k])));
  }
  CHECK(whole.iteration_cap_hits() == 0);
  CHECK(quarter.iteration_cap_hits() == 0);
}

TEST_CASE("A periodic sector restarts bit-identically and runs on two threads", "[sim][sector]") {
  Options o = sector(tight());
  o.tolerance = 1e-6;
  World a(o);
  build(a, 1);
  // Through the checkpoint file, at a step with a rope and a contact row across a seam.
  auto across = [&] {
    const WorldState st = a.state();
    bool rope = false, row = false;
    for (const auto& r : st.ropes) rope = rope || r.image != 0;
    for (const auto& c : st.contacts) row = row || c.image == 1;
    return rope && row;
  };
  int steps = 0;
  for (; steps < 400 && (steps < 50 || !across()); ++steps) a.step();
  REQUIRE(across());
  TempDir dir("sim_sector_ckpt");
  write_checkpoint(dir / "c.h5", a);
  World b = World::from_state(read_checkpoint(dir / "c.h5"));
  CHECK(b.state_hash() == a.state_hash());
  CHECK(b.options().sectors == kSectors);
  CHECK(b.options().sector_start == kStart);
  for (int k = 0; k < 150; ++k) {
    const auto da = a.step();
    const auto db = b.step();
    REQUIRE(da.iterations == db.iterations);
  }
  CHECK(a.state_hash() == b.state_hash());

  Options two = o;
  two.threads = 2;
  two.parallel_min_rows_per_thread = 0;
  World serial(o), threaded(two);
  const Scene s1 = build(serial, 1), s2 = build(threaded, 1);
  for (int k = 0; k < 300; ++k) {
    serial.step();
    threaded.step();
  }
  // Another Gauss–Seidel order at tolerance 1e-6: the same motion to a small fraction of d.
  for (std::size_t k = 0; k < s1.beads.size(); ++k)
    CHECK((serial.position(s1.beads[k]) - threaded.position(s2.beads[k])).norm() <= 1e-3 * kD);
}

TEST_CASE("A periodic sector refuses what it cannot hold", "[sim][sector]") {
  Options o = sector(tight());
  SECTION("a sector count out of range") {
    Options bad = o;
    bad.sectors = 2;
    CHECK_THROWS_AS(World(bad), shearzone::ConfigError);
  }
  World w(o);
  SECTION("a bead outside the wedge") {
    CHECK_THROWS_AS(w.add_sphere(polar(5 * kD, 90, 0), kD, kRho, BodyKind::kFixed), shearzone::ConfigError);
    CHECK_THROWS_AS(w.add_sphere(polar(5 * kD, 100, kD), kD, kRho), shearzone::ConfigError);
    CHECK_NOTHROW(w.add_sphere(polar(5 * kD, 10, kD), kD, kRho));
  }
  SECTION("a wall that is not horizontal") {
    CHECK_THROWS_AS(w.add_wall(Wall{Vec3::Zero(), Vec3::UnitX(), 0.3}), shearzone::ConfigError);
  }
  SECTION("a rotor off the sector's axis") {
    const int b = w.add_sphere(polar(2 * kD, 0, kD), kD, kRho, BodyKind::kKinematic);
    const std::vector<int> ids{b};
    CHECK_THROWS_AS(w.add_rotor(ids, Vec3(kD, 0, 0), Vec3::UnitZ(), 0.1, 1.0), shearzone::ConfigError);
  }
  SECTION("a vane that turns out of the wedge") {
    const int b = w.add_sphere(polar(3 * kD, 0, kD), kD, kRho, BodyKind::kKinematic);
    const std::vector<int> ids{b};
    w.add_rotor(ids, Vec3::Zero(), Vec3::UnitZ(), 1.0, 5.0);  // 1 rad > 45°
    CHECK_THROWS_AS([&] { for (int k = 0; k < 100; ++k) w.step(); }(), shearzone::NoResultError);
  }
}

TEST_CASE("A scene's periodic quarter holds one wedge of the cup", "[sim][sector]") {
  TempDir dir("sim_sector_scene");
  const auto file = dir / "q.toml";
  {
    std::ofstream f(file);
    f << "[sim]\nduration_s = 0\ntime_step_s = 1e-3\ntolerance = 1e-3\n"
         "[cylinder]\nradius_m = 0.024\nheight_m = 0.012\nbead_diameter_m = 0.004\nsectors = 4\n"
         "[beads]\ndiameter_m = 0.004\ndensity_kg_per_m3 = 7800\n"
         "[vane]\nradius_m = 0.01\nheight_m = 0.012\nphi0_rad = 0.3\nf_Hz = 1\n"
         "[fill]\ncount = 30\n";
  }
  const shearzone::sim::LoadedScene sc = shearzone::sim::load_scene(file, false);
  const World& w = *sc.world;
  CHECK(w.options().sectors == 4);
  CHECK(w.options().sector_start == kStart);
  int mobile = 0, vane = 0, wall_ring = 0;
  for (int b = 0; b < w.body_count(); ++b) {
    INFO("body " << b);
    CHECK(shearzone::sim::sector_contains(w.options(), w.position(b)));
    mobile += w.kind(b) == BodyKind::kMobile ? 1 : 0;
    vane += w.kind(b) == BodyKind::kKinematic ? 1 : 0;
    if (w.kind(b) == BodyKind::kFixed && w.position(b).z() == 0.002) ++wall_ring;
  }
  CHECK(mobile == 30);
  // Three layers of a hub and one blade of two beads (r = d, 2d within 10 mm).
  CHECK(vane == 3 * (1 + 2));
  CHECK(w.rotor(0).bodies.size() == 9u);
  // The first ring: ceil(2 pi 26 mm / 4 mm) = 41 beads, rounded up to 44, a quarter of them.
  CHECK(wall_ring == 11);
}

namespace {

/// Chain statistics of a placement seen periodically (images of a quarter turn, or none):
/// bonds, turning angles, the closest approach of any two beads (any images) and the mean
/// end-to-end distance of a chain grown through its bonds' nearest images.
struct ChainStats {
  double min_bond = 1e9, max_bond = 0.0, max_turn = 0.0, min_gap = 1e9, mean_end_to_end = 0.0;
  int crossing_bonds = 0;
};

ChainStats chain_stats(const shearzone::sim::ChainPlacement& p, bool quarter) {
  ChainStats st;
  const int n = p.beads_per_chain;
  const auto count = static_cast<int>(p.positions.size());
  auto nearest = [&](const Vec3& from, const Vec3& x, int* image) {
    Vec3 best = x;
    for (int m = 1; quarter && m < 4; ++m)
      if ((turn(x, m) - from).norm() < (best - from).norm()) {
        best = turn(x, m);
        if (image != nullptr) *image = m;
      }
    return best;
  };
  for (int c = 0; c * n < count; ++c) {
    std::vector<Vec3> walk{p.positions[static_cast<std::size_t>(c * n)]};
    for (int k = 1; k < n; ++k) {
      int image = 0;
      const Vec3 next = nearest(walk.back(), p.positions[static_cast<std::size_t>(c * n + k)], &image);
      const Vec3 bond = next - walk.back();
      st.crossing_bonds += image != 0 ? 1 : 0;
      st.min_bond = std::min(st.min_bond, bond.norm());
      st.max_bond = std::max(st.max_bond, bond.norm());
      if (k >= 2) {
        const Vec3 before = walk.back() - walk[walk.size() - 2];
        st.max_turn = std::max(st.max_turn, std::acos(std::clamp(before.dot(bond) / before.norm() / bond.norm(), -1.0, 1.0)));
      }
      walk.push_back(next);
    }
    st.mean_end_to_end += (walk.back() - walk.front()).norm();
  }
  st.mean_end_to_end /= count / n;
  for (int i = 0; i < count; ++i)
    for (int j = i + 1; j < count; ++j)
      if (!(p.chain_of_bead[static_cast<std::size_t>(i)] == p.chain_of_bead[static_cast<std::size_t>(j)] && j == i + 1)) {
        const Vec3& xi = p.positions[static_cast<std::size_t>(i)];
        st.min_gap = std::min(st.min_gap, (nearest(xi, p.positions[static_cast<std::size_t>(j)], nullptr) - xi).norm());
      }
  return st;
}

}  // namespace

TEST_CASE("Chains placed in a periodic quarter cross its sides as in the whole cup", "[sim][sector][builder]") {
  using shearzone::sim::CylinderRegion;
  // The paper's chains (d = 2.4 mm, l_max = d/6, 40°) of 9 beads at a 19 % volume fraction
  // in the annulus of the paper's cup around its vane, the quarter with a quarter of them.
  CylinderRegion whole;
  whole.radius = 0.0348;
  whole.inner_radius = 0.0108;
  whole.z1 = 0.04;
  CylinderRegion quarter = whole;
  quarter.sectors = kSectors;
  quarter.sector_start = kStart;
  shearzone::sim::ChainOptions o;
  o.beads_per_chain = 9;
  o.diameter = 0.0024;
  o.l_max = 0.0004;
  o.theta_max = 40.0 * std::numbers::pi / 180.0;
  o.chains = 400;
  o.seed = 7;
  const auto w = shearzone::sim::place_chains(whole, o);
  o.chains = 100;
  const auto q = shearzone::sim::place_chains(quarter, o);
  Options wedge;
  wedge.sectors = kSectors;
  wedge.sector_start = kStart;
  for (const Vec3& x : q.positions) REQUIRE(shearzone::sim::sector_contains(wedge, x));
  const ChainStats sw = chain_stats(w, false), sq = chain_stats(q, true);
  // Through the images the quarter's chains obey the same bonds, angles and clearance.
  CHECK(sq.min_bond >= o.diameter * (1 - 1e-12));
  CHECK(sq.max_bond <= (o.diameter + o.l_max) * (1 + 1e-12));
  CHECK(sq.max_turn <= o.theta_max + 1e-9);
  CHECK(sq.min_gap >= o.diameter * (1 + o.clearance) * (1 - 1e-12));
  // They cross the sides (a wedge holding every chain whole would fold them into it) ...
  CHECK(sq.crossing_bonds > 20);
  // ... and are as extended as in the whole cup: mean end-to-end distance within 5 %
  // (seed-to-seed s.d. of the quarter's mean over 100 chains: 1.3 %, of the whole cup's over 400:
  // 0.7 %, seeds 1-8; the 5 % bound is 3.5 s.d.).
  INFO("end-to-end: whole " << sw.mean_end_to_end << " m, quarter " << sq.mean_end_to_end << " m, crossing bonds "
                            << sq.crossing_bonds);
  CHECK(std::abs(sq.mean_end_to_end / sw.mean_end_to_end - 1.0) < 0.05);
  CHECK(sw.crossing_bonds == 0);
}

TEST_CASE("The camera sees a periodic quarter as the whole cup", "[sim][sector]") {
  Options o = tight();
  testutil::set_solver(o, testutil::Solver::forward);
  World whole(o), quarter(sector(o));
  build(whole, 4);
  build(quarter, 1);
  shearzone::sim::SurfaceCameraOptions co;
  co.m_per_px = kD / 10.0;
  co.spacing_px = 2.0;
  co.width_px = co.height_px = 200;  // ±10 d about the axis
  co.centre_x_px = co.centre_y_px = 99.5;
  shearzone::sim::SurfaceCamera cw(co), cq(co);
  cw.record(whole);
  cq.record(quarter);
  int wrapped_seen = 0;
  for (int frame = 0; frame < 5; ++frame) {
    std::vector<Vec3> before;
    for (int b = 0; b < quarter.body_count(); ++b) before.push_back(quarter.position(b));
    for (int k = 0; k < 40; ++k) {
      whole.step();
      quarter.step();
    }
    for (int b = 0; b < quarter.body_count(); ++b) wrapped_seen += (quarter.position(b) - before[static_cast<std::size_t>(b)]).norm() > kD ? 1 : 0;
    const shearzone::core::VectorField fw = cw.pair(whole), fq = cq.pair(quarter);
    REQUIRE(fw.u_px.size() == fq.u_px.size());
    int valid = 0;
    for (std::size_t n = 0; n < fw.u_px.size(); ++n) {
      INFO("frame " << frame << " node " << n);
      REQUIRE(fw.flag[n] == fq.flag[n]);
      if (fw.flag[n] != shearzone::core::VectorFlag::kValid) continue;
      ++valid;
      // The two runs agree to ~1e-9 m (the first test): 1e-5 px at 1e-3 m per px.
      CHECK(std::abs(fw.u_px[n] - fq.u_px[n]) <= 1e-4);
      CHECK(std::abs(fw.v_px[n] - fq.v_px[n]) <= 1e-4);
    }
    CHECK(valid > 100);
  }
  CHECK(wrapped_seen > 0);  // a bead moved to its image between two frames
}

TEST_CASE("A periodic sector's state is checked on restart", "[sim][sector]") {
  Options o = sector(tight());
  o.tolerance = 1e-6;
  World a(o);
  build(a, 1);
  for (int k = 0; k < 60; ++k) a.step();
  const WorldState good = a.state();
  WorldState s = good;
  s.ropes[0].image = 2;  // more than one wedge apart
  CHECK_THROWS_WITH(World::from_state(s), Catch::Matchers::Contains("image 2"));
  s = good;
  s.angles[0].image_next = -2;
  CHECK_THROWS_WITH(World::from_state(s), Catch::Matchers::Contains("image -2"));
  s = good;
  s.options.sectors = 0;  // a rope across a seam without a sector
  s.ropes[0].image = 1;
  CHECK_THROWS_WITH(World::from_state(s), Catch::Matchers::Contains("image 1"));
  s = good;
  s.options.sectors = 2;
  CHECK_THROWS_WITH(World::from_state(s), Catch::Matchers::Contains("sectors"));
  CHECK_NOTHROW(World::from_state(good));
}
