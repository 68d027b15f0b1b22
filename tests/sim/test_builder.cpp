// Chain builder (placement invariants, determinism, fill), sphere–region volumes, and
// the packing anchors ([slow]): random loose packing of poured spheres at μ ≈ 0.2 and
// φ falling with the chain length N (Zou et al., Science 326, 408 (2009)).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include <catch2/catch.hpp>

#include "shearzone/sim/builder.hpp"
#include "sim/sim_test_util.hpp"

using namespace shearzone::sim;
using namespace testutil;

namespace {

constexpr double kPi = std::numbers::pi;
/// Round-off allowance on distances computed from placed coordinates (relative to d).
constexpr double kRound = 1e-12;
/// Quadrature accuracy claimed in builder.hpp for sphere_region_volume (relative).
constexpr double kVolumeTol = 1e-10;

double sphere_volume(double r) { return 4.0 / 3.0 * kPi * r * r * r; }

/// Checks the placement invariants; returns the worst turning angle.
double check_placement(const ChainPlacement& p, const ChainOptions& o, const Region& region) {
  const double d = o.diameter, r = 0.5 * d;
  const int n = o.beads_per_chain;
  REQUIRE(p.positions.size() == static_cast<std::size_t>(o.chains * n));
  REQUIRE(p.chain_of_bead.size() == p.positions.size());
  double worst_angle = 0.0;
  for (std::size_t i = 0; i < p.positions.size(); ++i) {
    const Vec3& x = p.positions[i];
    CHECK(p.chain_of_bead[i] == static_cast<int>(i) / n);
    // Inside the region (the whole bead).
    if (const auto* b = std::get_if<BoxRegion>(&region)) {
      CHECK(((x.array() - r) >= b->lo.array() - kRound * d).all());
      CHECK(((x.array() + r) <= b->hi.array() + kRound * d).all());
    } else {
      const auto& c = std::get<CylinderRegion>(region);
      CHECK(std::hypot(x.x() - c.cx, x.y() - c.cy) <= c.radius - r + kRound * d);
      CHECK(x.z() >= c.z0 + r - kRound * d);
      CHECK(x.z() <= c.z1 - r + kRound * d);
    }
    const bool bonded_prev = i % static_cast<std::size_t>(n) != 0;
    if (bonded_prev) {
      const double len = (x - p.positions[i - 1]).norm();
      CHECK(len >= d * (1.0 - kRound));
      CHECK(len <= (d + o.l_max) * (1.0 + kRound));
      if (i % static_cast<std::size_t>(n) >= 2) {
        const Vec3 b1 = p.positions[i - 1] - p.positions[i - 2], b2 = x - p.positions[i - 1];
        const double ang = std::acos(std::clamp(b1.dot(b2) / (b1.norm() * b2.norm()), -1.0, 1.0));
        worst_angle = std::max(worst_angle, ang);
      }
    }
    // No overlaps: every pair at ≥ d, non-bonded pairs at ≥ d (1 + clearance).
    for (std::size_t j = 0; j < i; ++j) {
      const double dist = (x - p.positions[j]).norm();
      const bool bonded = bonded_prev && j == i - 1;
      if (bonded) continue;
      if (dist < d * (1.0 + o.clearance) * (1.0 - kRound)) {
        FAIL_CHECK("beads " << j << " and " << i << " at " << dist / d << " d");
      }
    }
  }
  CHECK(worst_angle <= o.theta_max + 1e-12);
  return worst_angle;
}

/// Chains of n beads (l_max = 0.1 d, at most 60 degrees) filled into `region`, walls and
/// beads at friction mu, inserted in the lowest `insert` of the region.
FillOptions chain_fill(int chains, int n, std::uint64_t seed, const BoxRegion& region, double mu, double insert) {
  FillOptions f;
  f.chains.diameter = kD;
  f.chains.density = kRho;
  f.chains.chains = chains;
  f.chains.beads_per_chain = n;
  f.chains.l_max = 0.1 * kD;
  f.chains.theta_max = deg(60.0);
  f.chains.seed = seed;
  f.region = region;
  f.wall_friction = mu;
  f.insert_fraction = insert;
  return f;
}

}  // namespace

TEST_CASE("Chain placement: no overlaps, bond lengths, turning angles, inside, deterministic",
          "[sim][builder]") {
  ChainOptions o;
  o.diameter = kD;
  o.density = kRho;
  o.l_max = 0.2 * kD;
  o.theta_max = deg(60.0);
  o.seed = 5;

  SECTION("chains of 12 in a box") {
    o.chains = 30;
    o.beads_per_chain = 12;
    const Region box = BoxRegion{Vec3::Zero(), Vec3(10, 10, 12) * kD};
    const ChainPlacement a = place_chains(box, o);
    const double worst = check_placement(a, o, box);
    INFO("worst turning angle " << worst << " rad, restarts " << a.restarts);
    CHECK(worst > 0.5 * o.theta_max);  // the walk really turns
    const ChainPlacement b = place_chains(box, o);
    CHECK(a.positions == b.positions);
    o.seed = 6;
    const ChainPlacement c = place_chains(box, o);
    CHECK(a.positions != c.positions);
  }
  SECTION("chains of 9 in a cylinder") {
    o.chains = 20;
    o.beads_per_chain = 9;
    const Region cyl = CylinderRegion{0.1, -0.2, 6.0 * kD, 0.0, 10.0 * kD};
    check_placement(place_chains(cyl, o), o, cyl);
  }
  SECTION("single beads, l_max = 0") {
    o.chains = 200;
    o.beads_per_chain = 1;
    o.l_max = 0.0;
    const Region box = BoxRegion{Vec3(-1, -1, 0) * kD, Vec3(7, 7, 10) * kD};
    check_placement(place_chains(box, o), o, box);
  }
  SECTION("rigid-bond chains, l_max = 0") {
    o.chains = 10;
    o.beads_per_chain = 20;
    o.l_max = 0.0;
    const Region box = BoxRegion{Vec3::Zero(), Vec3(12, 12, 12) * kD};
    check_placement(place_chains(box, o), o, box);
  }
  SECTION("a region too dense for the chains fails with NoResultError") {
    o.chains = 400;
    o.beads_per_chain = 5;
    o.max_attempts = 20;
    CHECK_THROWS_AS(place_chains(BoxRegion{Vec3::Zero(), Vec3(5, 5, 5) * kD}, o), shearzone::NoResultError);
  }
}

TEST_CASE("Builder options are validated and named", "[sim][builder]") {
  const Region box = BoxRegion{Vec3::Zero(), Vec3(5, 5, 5) * kD};
  auto message = [&](ChainOptions o) {
    try {
      (void)place_chains(box, o);
    } catch (const shearzone::ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  ChainOptions o;
  o.diameter = kD;
  auto with = [&](auto edit) {
    ChainOptions c = o;
    edit(c);
    return c;
  };
  CHECK_THAT(message(with([](ChainOptions& c) { c.beads_per_chain = 0; })),
             Catch::Contains("chains.beads_per_chain"));
  CHECK_THAT(message(with([](ChainOptions& c) { c.theta_max = 4.0; })), Catch::Contains("chains.theta_max"));
  CHECK_THAT(message(with([](ChainOptions& c) { c.l_max = -1e-3; })), Catch::Contains("chains.l_max"));
  CHECK_THAT(message(with([](ChainOptions& c) { c.diameter = 0.0; })), Catch::Contains("chains.diameter"));
  CHECK_THROWS_AS(place_chains(BoxRegion{Vec3::Zero(), Vec3(1, -1, 1)}, o), shearzone::ConfigError);
  FillOptions f;
  f.chains = o;
  f.insert_fraction = 0.5;
  CHECK_THROWS_WITH(validate(f), Catch::Contains("insert_fraction"));
  f.insert_fraction = 0.2;
  f.region = CylinderRegion{};
  CHECK_THROWS_WITH(fill(Options{}, f), Catch::Contains("container"));
}

TEST_CASE("Sphere–region volumes: caps, box partitions, cylinder", "[sim][builder]") {
  const double r = 0.5 * kD;
  const Vec3 c(0.013, -0.004, 0.021);
  const double v = sphere_volume(r);
  // A face cutting the sphere at distance a from the centre: the cap π h²(3r − h)/3.
  for (const double a : {-0.7 * r, -0.2 * r, 0.0, 0.35 * r, 0.9 * r}) {
    const double hcap = r - a;
    const double cap = kPi * hcap * hcap * (3.0 * r - hcap) / 3.0;
    for (int axis = 0; axis < 3; ++axis) {
      BoxRegion b{c - Vec3::Constant(2 * r), c + Vec3::Constant(2 * r)};
      b.lo[axis] = c[axis] + a;
      INFO("axis " << axis << " a/r " << a / r);
      CHECK(std::abs(sphere_region_volume(c, r, b) - cap) <= kVolumeTol * v);
    }
  }
  // Eight boxes that partition space around an off-centre corner sum to the sphere.
  const Vec3 cut = c + Vec3(0.31, -0.22, 0.13) * r;
  double sum = 0.0, eighth = 0.0;
  for (int k = 0; k < 8; ++k) {
    BoxRegion b{c - Vec3::Constant(3 * r), c + Vec3::Constant(3 * r)};
    for (int axis = 0; axis < 3; ++axis) ((k >> axis) & 1 ? b.lo : b.hi)[axis] = cut[axis];
    sum += sphere_region_volume(c, r, b);
  }
  CHECK(std::abs(sum - v) <= kVolumeTol * v);
  // Centre on a box corner: exactly one eighth.
  eighth = sphere_region_volume(c, r, BoxRegion{c, c + Vec3::Constant(r)});
  CHECK(std::abs(eighth - v / 8.0) <= kVolumeTol * v);
  // Coaxial cylinder of radius R < r: 4π/3 (r³ − (r² − R²)^{3/2}).
  for (const double R : {0.3 * r, 0.8 * r}) {
    const double exact = 4.0 / 3.0 * kPi * (r * r * r - std::pow(r * r - R * R, 1.5));
    const double got = sphere_region_volume(c, r, CylinderRegion{c.x(), c.y(), R, c.z() - r, c.z() + r});
    CHECK(std::abs(got - exact) <= kVolumeTol * v);
  }
  // Off-axis cylinder against a Monte-Carlo estimate (4·10⁵ points, σ ≈ 1.5e-3 of V).
  const CylinderRegion cyl{c.x() + 0.6 * r, c.y(), 0.9 * r, c.z() - 0.5 * r, c.z() + 2 * r};
  std::mt19937_64 rng(3);
  int hit = 0, in = 0;
  for (int k = 0; k < 400000; ++k) {
    Vec3 p;
    for (int a = 0; a < 3; ++a) p[a] = (static_cast<double>(rng() >> 11U) * 0x1.0p-53 * 2.0 - 1.0) * r;
    if (p.squaredNorm() > r * r) continue;
    ++in;
    const Vec3 q = c + p;
    if (std::hypot(q.x() - cyl.cx, q.y() - cyl.cy) <= cyl.radius && q.z() >= cyl.z0 && q.z() <= cyl.z1) ++hit;
  }
  const double mc = v * hit / in;
  CHECK(std::abs(sphere_region_volume(c, r, cyl) - mc) <= 5e-3 * v);  // > 3σ
}

TEST_CASE("A small fill of chains settles", "[sim][builder]") {
  // 16 chains of 6 beads (96 beads) into a box 6 d × 6 d; the drop runs at a loose
  // tolerance, the relaxation at the default-like one.
  const Options wo{.time_step = 5e-4, .friction = 0.3, .tolerance = 1e-3, .max_iterations = 200};
  FillOptions f = chain_fill(16, 6, 2, BoxRegion{Vec3::Zero(), Vec3(6, 6, 10) * kD}, 0.3, 0.2);
  f.relax_kinetic_energy = 1e-5;
  const auto t0 = std::chrono::steady_clock::now();
  const FillResult a = fill(wo, f);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  double top = 0.0, worst_overlap = 0.0;
  for (const int b : a.beads) top = std::max(top, a.world.position(b).z());
  for (const auto& c : a.world.contacts()) worst_overlap = std::max(worst_overlap, -c.gap / kD);
  WARN("small fill: " << a.settle_steps << " drop steps (" << a.settle_cap_hits << " cap hits), "
                      << a.relax_steps << " relax steps, KE/(n m g d) " << a.kinetic_energy << ", top bead "
                      << top / kD << " d, max overlap " << worst_overlap << " d, " << seconds << " s");
  CHECK(a.relaxed);
  CHECK(a.kinetic_energy <= f.relax_kinetic_energy);
  CHECK(worst_overlap < 0.01);  // 1 % of d: well under the 5 % divergence threshold
  CHECK(top < 8.0 * kD);        // everything came down
  CHECK(a.beads.size() == 96);
  CHECK(a.chain_of_bead.back() == 15);
  CHECK(a.world.rope_count() == 16 * 5);
  CHECK(a.world.angle_count() == 16 * 4);
  // Deterministic for a seed.
  const FillResult b = fill(wo, f);
  CHECK(a.world.state_hash() == b.world.state_hash());
}

namespace {

/// One poured packing for the [slow] packing test; returns φ in the measurement region.
struct PackingRun {
  double phi = 0.0, seconds = 0.0, kinetic_energy = 0.0;
  std::int64_t settle_steps = 0, relax_steps = 0;
  int spheres = 0;
  double z_hi = 0.0;
  bool relaxed = false;
};

PackingRun pour(int n, std::uint64_t seed) {
  // 1710 beads (= 38 × 45 = 190 × 9) in a 12 d × 12 d box: a pile about 10 d high.
  constexpr int kBeads = 1710;
  constexpr double kWidth = 12.0, kWall = 2.0;  // box width, wall exclusion (× d)
  // Chains need 40-150 sweeps at 1e-3 (a cap of 100 is hit every step).
  const Options wo{.time_step = 5e-4, .friction = 0.2, .tolerance = 1e-3, .max_iterations = 400};
  FillOptions f = chain_fill(kBeads / n, n, seed, BoxRegion{Vec3::Zero(), Vec3(kWidth, kWidth, 20.0) * kD}, 0.2, 0.25);
  // Chain beads on the surface keep rolling (no rolling resistance): 1e-4 m g d per
  // bead is one bead in 1710 at 0.2 m/s. The interior, where φ is measured, is at rest.
  f.relax_kinetic_energy = 1e-4;
  f.relax_max_steps = 1500;
  const auto t0 = std::chrono::steady_clock::now();
  const FillResult r = fill(wo, f);
  PackingRun out;
  out.relaxed = r.relaxed;
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  out.settle_steps = r.settle_steps;
  out.relax_steps = r.relax_steps;
  out.kinetic_energy = r.kinetic_energy;
  // Free surface: the 95th percentile of the bead heights lies in the top layer; stay
  // kWall d below it as from the walls.
  std::vector<double> z;
  for (const int b : r.beads) z.push_back(r.world.position(b).z());
  std::sort(z.begin(), z.end());
  const double z95 = z[static_cast<std::size_t>(0.95 * static_cast<double>(z.size()))];
  out.z_hi = z95 - kWall * kD;
  const PackingMeasurement m = packing_fraction(
      r.world, BoxRegion{Vec3(kWall, kWall, kWall) * kD, Vec3(kWidth - kWall, kWidth - kWall, 0.0) * kD +
                                                              Vec3(0.0, 0.0, out.z_hi)});
  out.phi = m.fraction;
  out.spheres = m.spheres;
  return out;
}

}  // namespace

TEST_CASE("Packing: poured single beads near random loose packing, chains looser (Zou et al.)",
          "[sim][builder][slow]") {
  // Gates of docs/sim.md ("Chain builder and packing"): ⟨φ⟩(N = 1, μ = 0.2) in [0.57, 0.64]
  // over 3 seeds; N = 9 and N = 45 each at least 0.02 below N = 1.
  std::vector<std::pair<int, double>> mean;
  for (const int n : {1, 9, 45}) {
    double sum = 0.0;
    for (const std::uint64_t seed : {1U, 2U, 3U}) {
      const PackingRun p = pour(n, seed);
      WARN("N = " << n << " seed " << seed << ": phi " << p.phi << " (" << p.spheres << " spheres, top of region "
                  << p.z_hi / kD << " d), " << p.settle_steps << " drop + " << p.relax_steps
                  << " relax steps, KE_t/(n m g d) " << p.kinetic_energy << (p.relaxed ? "" : " (not relaxed)") << ", " << p.seconds << " s");
      sum += p.phi;
    }
    mean.emplace_back(n, sum / 3.0);
    WARN("N = " << n << ": mean phi " << sum / 3.0);
  }
  CHECK(mean[0].second >= 0.57);
  CHECK(mean[0].second <= 0.64);
  CHECK(mean[1].second <= mean[0].second - 0.02);
  CHECK(mean[2].second <= mean[0].second - 0.02);
}

TEST_CASE("an annulus region (the cup around its vane): placement stays between the radii, volumes add up",
          "[sim][builder]") {
  const CylinderRegion c{.radius = 0.03, .z0 = 0.0, .z1 = 0.02, .inner_radius = 0.01};
  ChainOptions o;
  o.chains = 80;
  o.beads_per_chain = 3;
  o.diameter = 0.004;
  o.l_max = 0.0004;
  const ChainPlacement p = place_chains(c, o);
  REQUIRE(p.positions.size() == 240);
  for (const Vec3& x : p.positions) {
    const double rho = std::hypot(x.x(), x.y());
    CHECK(rho >= c.inner_radius + 0.002 - 1e-12);
    CHECK(rho <= c.radius - 0.002 + 1e-12);
  }
  // A sphere straddling the inner wall: its volume in the annulus is the whole sphere's
  // minus the part inside the inner cylinder (the two cut at the same wall).
  CylinderRegion inner = c;
  inner.inner_radius = 0.0;
  inner.radius = c.inner_radius;
  const Vec3 at(0.0105, 0, 0.01);
  const double whole = 4.0 / 3.0 * M_PI * std::pow(0.002, 3);
  CHECK(sphere_region_volume(at, 0.002, c) + sphere_region_volume(at, 0.002, inner) == Approx(whole).epsilon(1e-9));
  CHECK(sphere_region_volume(at, 0.002, c) > 0.4 * whole);
  CylinderRegion bad = c;
  bad.inner_radius = 0.04;
  CHECK_THROWS_AS(validate(Region{bad}), shearzone::ConfigError);
}
