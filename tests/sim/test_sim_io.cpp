// The simulator's files: checkpoint/restart continues bit-identically, the snapshot
// XDMF is well-formed XML whose HDF5 references exist with the stated shapes, and the
// diagnostics CSV has its columns.
#include <cstddef>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "shearzone/io/csv.hpp"
#include "shearzone/io/hdf5.hpp"
#include "shearzone/sim/sim_io.hpp"
#include "sim/sim_test_util.hpp"
#include "support/temp_dir.hpp"

using namespace shearzone::sim;
using namespace testutil;
using shearzone::testing::TempDir;

namespace {

/// A box of walls with a fixed bead, a kinematic bead, two angle-limited chains and
/// single beads falling onto each other: every kind of row and body.
World make_scene(Solver solver = Solver::alternate) {
  // A sweep cap low enough to be hit now and then.
  const Options o =
      solver_options(solver, {.time_step = 5e-4, .friction = 0.3, .tolerance = 1e-5, .max_iterations = 60});
  World w(o);
  const double half = 3.0 * kD;
  w.add_wall(Wall{Vec3::Zero(), Vec3::UnitZ(), 0.4});
  w.add_wall(Wall{Vec3(-half, 0, 0), Vec3::UnitX(), 0.3});
  w.add_wall(Wall{Vec3(half, 0, 0), -Vec3::UnitX(), 0.3});
  w.add_wall(Wall{Vec3(0, -half, 0), Vec3(0.0, 1.0, 0.001), 0.3});
  w.add_wall(Wall{Vec3(0, half, 0), -Vec3::UnitY(), 0.3});
  w.add_sphere(Vec3(0, 0, 0.5 * kD), kD, kRho, BodyKind::kFixed);
  const int kin = w.add_sphere(Vec3(2.0 * kD, 2.0 * kD, 0.5 * kD), kD, kRho, BodyKind::kKinematic);
  w.set_angular_velocity(kin, Vec3(0, 0, 3.0));
  for (int c = 0; c < 2; ++c) {
    std::vector<int> beads;
    for (int k = 0; k < 5; ++k)
      beads.push_back(w.add_sphere(Vec3((-2.0 + k) * 1.05 * kD, (c - 0.5) * 2.2 * kD,
                                        (2.0 + 1.3 * c + 0.01 * k) * kD),
                                   kD, kRho));
    w.add_chain(beads, 1.1 * kD, deg(60.0));
  }
  for (int k = 0; k < 16; ++k)
    w.add_sphere(Vec3((-1.5 + (k % 4)) * 1.1 * kD + 0.001 * k, (-1.5 + (k / 4)) * 1.1 * kD,
                      (5.0 + 0.3 * (k % 3)) * kD),
                 (k % 2 ? 1.0 : 0.9) * kD, kRho);
  return w;
}

/// Minimal XML check: balanced, properly nested tags; returns every element's
/// attributes and text, in document order (elements named by their tag).
struct XmlElement {
  std::string tag;
  std::map<std::string, std::string> attributes;
  std::string text;
};
std::vector<XmlElement> parse_xml(const std::string& xml) {
  std::vector<XmlElement> all;
  std::vector<std::size_t> open;
  std::size_t pos = 0;
  const std::regex attr_re(R"re(([A-Za-z_][A-Za-z0-9_]*)="([^"]*)")re");
  while ((pos = xml.find('<', pos)) != std::string::npos) {
    const std::size_t end = xml.find('>', pos);
    REQUIRE(end != std::string::npos);
    const std::string tag = xml.substr(pos + 1, end - pos - 1);
    if (!open.empty()) {
      const std::size_t prev_end = xml.rfind('>', pos - 1);
      if (prev_end != std::string::npos) all[open.back()].text += xml.substr(prev_end + 1, pos - prev_end - 1);
    }
    pos = end + 1;
    if (tag.empty() || tag[0] == '?' || tag[0] == '!') continue;
    if (tag[0] == '/') {
      REQUIRE_FALSE(open.empty());
      REQUIRE(all[open.back()].tag == tag.substr(1));
      open.pop_back();
      continue;
    }
    const bool self_closing = tag.back() == '/';
    XmlElement e;
    e.tag = tag.substr(0, tag.find_first_of(" /"));
    for (std::sregex_iterator it(tag.begin(), tag.end(), attr_re), stop; it != stop; ++it)
      e.attributes[(*it)[1]] = (*it)[2];
    all.push_back(e);
    if (!self_closing) open.push_back(all.size() - 1);
  }
  REQUIRE(open.empty());
  return all;
}

std::vector<std::size_t> parse_dims(const std::string& s) {
  std::istringstream in(s);
  std::vector<std::size_t> d;
  std::size_t v = 0;
  while (in >> v) d.push_back(v);
  return d;
}

}  // namespace

TEST_CASE("A restart from a checkpoint continues bit-identically", "[sim]") {
  const Solver solver = GENERATE(Solver::alternate, Solver::forward, Solver::anderson);  // every solver
  TempDir dir("sim_ckpt");
  World a = make_scene(solver);
  for (int k = 0; k < 300; ++k) a.step();
  REQUIRE_FALSE(a.contacts().empty());
  REQUIRE(a.rope_count() == 8);
  const std::uint64_t at_checkpoint = a.state_hash();
  write_checkpoint(dir / "c.h5", a, {{"tool", "test"}});

  const WorldState s = read_checkpoint(dir / "c.h5");
  World b = World::from_state(s);
  CHECK(b.state_hash() == at_checkpoint);
  CHECK(b.steps_done() == 300);
  CHECK(b.iteration_cap_hits() == a.iteration_cap_hits());
  CHECK(b.time() == a.time());
  for (int k = 0; k < 300; ++k) {
    const StepDiagnostics da = a.step();
    const StepDiagnostics db = b.step();
    REQUIRE(da.iterations == db.iterations);
    REQUIRE(da.residual == db.residual);
  }
  CHECK(a.state_hash() == b.state_hash());
  CHECK(a.iteration_cap_hits() == b.iteration_cap_hits());
  INFO("cap hits " << a.iteration_cap_hits());
  CHECK(a.contacts().size() == b.contacts().size());

  // The warm-start impulses matter: dropping them gives another trajectory.
  WorldState cold = s;
  cold.contacts.clear();
  for (auto& r : cold.ropes) r.impulse = 0.0;
  World c = World::from_state(cold);
  for (int k = 0; k < 300; ++k) c.step();
  CHECK(c.state_hash() != a.state_hash());
}

TEST_CASE("Checkpoint reading rejects bad files and inconsistent states", "[sim]") {
  TempDir dir("sim_ckpt_bad");
  {
    auto f = shearzone::io::H5File::create(dir / "x.h5");
    f.set_attribute("/", "format", "something else");
    f.close();
  }
  CHECK_THROWS_AS(read_checkpoint(dir / "x.h5"), shearzone::InputError);
  CHECK_THROWS_AS(read_checkpoint(dir / "missing.h5"), shearzone::InputError);
  World a = make_scene();
  for (int k = 0; k < 50; ++k) a.step();
  WorldState s = a.state();
  s.ropes[0].j = 1000;
  CHECK_THROWS_AS(World::from_state(s), shearzone::ConfigError);
  s = a.state();
  s.mass.pop_back();
  CHECK_THROWS_AS(World::from_state(s), shearzone::ConfigError);
  s = a.state();
  REQUIRE(s.contacts.size() >= 2);
  std::swap(s.contacts[0], s.contacts[1]);
  CHECK_THROWS_AS(World::from_state(s), shearzone::ConfigError);
  s = a.state();
  s.orientation[0].coeffs() *= 2.0;  // not a unit quaternion
  CHECK_THROWS_WITH(World::from_state(s), Catch::Matchers::Contains("orientation quaternion of norm 2"));
  s = a.state();
  s.options.threads = 0;
  CHECK_THROWS_WITH(World::from_state(s), Catch::Matchers::Contains("threads"));
  s = a.state();
  s.options.freeze_sweeps = -1;
  CHECK_THROWS_WITH(World::from_state(s), Catch::Matchers::Contains("freeze_sweeps"));
}

TEST_CASE("A checkpoint keeps the orientations, the thread count, the freeze setting, the sweep order and the Anderson depth", "[sim]") {
  TempDir dir("sim_ckpt_v2");
  World a = make_scene();
  for (int k = 0; k < 30; ++k) a.step();
  WorldState s = a.state();
  s.options.threads = 2;
  s.options.freeze_sweeps = 5;
  s.options.alternate_sweeps = false;
  s.options.anderson_depth = 4;
  const World b = World::from_state(s);
  write_checkpoint(dir / "c.h5", b);
  const WorldState r = read_checkpoint(dir / "c.h5");
  CHECK(r.options.threads == 2);
  CHECK(r.options.freeze_sweeps == 5);
  CHECK_FALSE(r.options.alternate_sweeps);
  CHECK(r.options.anderson_depth == 4);
  REQUIRE(r.orientation.size() == s.orientation.size());
  for (std::size_t k = 0; k < r.orientation.size(); ++k)
    CHECK(r.orientation[k].coeffs() == s.orientation[k].coeffs());  // bit-exact
}

TEST_CASE("Chain ids come from the rope graph", "[sim]") {
  const World w = make_scene();
  const auto id = chain_ids_from_ropes(w.state());
  REQUIRE(id.size() == static_cast<std::size_t>(w.body_count()));
  CHECK(id[0] == 0);  // fixed bead
  CHECK(id[1] == 1);  // kinematic bead
  for (int k = 2; k < 7; ++k) CHECK(id[static_cast<std::size_t>(k)] == 2);
  for (int k = 7; k < 12; ++k) CHECK(id[static_cast<std::size_t>(k)] == 3);
  CHECK(id[12] == 4);
  CHECK(id.back() == 4 + 15);
}

TEST_CASE("Snapshot XDMF is well-formed and references existing HDF5 datasets", "[sim]") {
  TempDir dir("sim_snap");
  World w = make_scene();
  const std::size_t n = static_cast<std::size_t>(w.body_count());
  SnapshotWriter snaps(dir / "snapshots.h5", w, {{"tool", "test"}});
  snaps.append(w);
  for (int k = 0; k < 3; ++k) {
    for (int s = 0; s < 10; ++s) w.step();
    snaps.append(w);
  }
  snaps.close();
  REQUIRE(snaps.snapshot_count() == 4);
  std::ostringstream xdmf;
  write_snapshot_xdmf(xdmf, "snapshots.h5", n, snaps.times());
  const auto elements = parse_xml(xdmf.str());

  const auto h5 = shearzone::io::H5File::open_read(dir / "snapshots.h5");
  int grids = 0, hdf_items = 0, times = 0;
  for (const auto& e : elements) {
    if (e.tag == "Grid" && e.attributes.count("GridType") && e.attributes.at("GridType") == "Uniform") ++grids;
    if (e.tag == "Time") ++times;
    if (e.tag != "DataItem" || !e.attributes.count("Format") || e.attributes.at("Format") != "HDF") continue;
    ++hdf_items;
    std::string ref = e.text;
    ref.erase(0, ref.find_first_not_of(" \n"));
    ref.erase(ref.find_last_not_of(" \n") + 1);
    const std::size_t colon = ref.find(':');
    REQUIRE(colon != std::string::npos);
    CHECK(ref.substr(0, colon) == "snapshots.h5");
    const std::string ds = ref.substr(colon + 1);
    INFO(ds);
    REQUIRE(h5.exists(ds));
    CHECK(h5.dims(ds) == parse_dims(e.attributes.at("Dimensions")));
  }
  CHECK(grids == 4);
  CHECK(times == 4);
  CHECK(hdf_items == 4 * 6);
  CHECK(h5.dims("/position") == std::vector<std::size_t>{4, n, 3});
  const auto pos = h5.read<double>("/position");
  const auto t = h5.read<double>("/time_s");
  CHECK(t.data.back() == w.time());
  CHECK(pos.data[3 * 3 * n + 3 * (n - 1) + 2] == w.position(static_cast<int>(n) - 1).z());
  const auto chain = h5.read<std::int64_t>("/chain_id");
  CHECK(chain.data[3] == 2);
}

TEST_CASE("The diagnostics CSV has one row per step with unit-suffixed columns", "[sim]") {
  World w = make_scene();
  std::ostringstream out;
  {
    DiagnosticsCsv csv(out, {{"tool", "shearzone"}, {"time_step_s", "0.0005"}});
    for (int k = 0; k < 5; ++k) {
      const StepDiagnostics d = w.step();
      csv.row(d, w.time());
    }
  }
  const auto t = shearzone::io::parse_csv(out.str(), "diagnostics.csv");
  CHECK(t.columns == DiagnosticsCsv::columns());
  for (const char* c : {"step", "time_s", "iterations", "residual", "cap_hit", "active_contacts",
                        "sliding_contacts", "sticking_contacts", "max_overlap_over_d",
                        "max_rope_excess_over_d", "max_angle_excess_rad", "kinetic_energy_J"})
    CHECK(t.has_column(c));
  REQUIRE(t.num_rows() == 5);
  CHECK(t.numeric_column("step").back() == 5.0);
  CHECK(t.numeric_column("time_s").back() == w.time());
  CHECK(shearzone::core::metadata_value(t.metadata, "time_step_s") == "0.0005");
}
