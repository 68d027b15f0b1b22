// The scene file as values (sim/scene.hpp): read_scene then build_scene is load_scene, a
// spec written and read back is the same spec, and a spec built or changed in code builds
// what it says and is refused as a file is.
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <type_traits>

#include <catch2/catch.hpp>

#include "shearzone/core/error.hpp"
#include "shearzone/sim/scene.hpp"

using namespace shearzone;
using namespace shearzone::sim;

namespace {
const std::filesystem::path kFilmedCup =
    std::filesystem::path(SHEARZONE_DATA_SAMPLES_DIR) / "sim" / "filmed_cup.toml";

/// Every key of two specs equal (values, not their sources).
bool same_keys(const SceneSpec& a, const SceneSpec& b) {
  bool same = true;
  SceneSpec::for_each_key(a, [&](const char* name, const auto& key) {
    SceneSpec::for_each_key(b, [&](const char* other, const auto& theirs) {
      if constexpr (std::is_same_v<decltype(key), decltype(theirs)>)
        if (std::string(name) == other && key != theirs) same = false;
    });
  });
  return same;
}
}  // namespace

TEST_CASE("a scene read into a spec and built is the world load_scene builds, and a spec changed as a value "
          "builds the change",
          "[sim][scene]") {
  const SceneSpec spec = read_scene(kFilmedCup);
  CHECK(spec.camera.fps == 25.0);
  CHECK(spec.sim.duration_s == 0.16);
  CHECK(spec.sim.time_step_s == 1e-3);
  CHECK(spec.cylinder.radius_m == 0.024);
  CHECK(spec.fill.count == 60);
  CHECK(spec.fill.settle == true);
  CHECK_FALSE(spec.fill.seed.has_value());  // absent: the documented default
  CHECK(spec.lines.at("vane.phi0_rad") == 28);

  const LoadedScene loaded = load_scene(kFilmedCup, false);
  const LoadedScene built = build_scene(spec, false);
  REQUIRE(loaded.world.has_value());
  REQUIRE(built.world.has_value());
  CHECK(built.world->state_hash() == loaded.world->state_hash());
  CHECK(built.chain_ids == loaded.chain_ids);
  CHECK(built.mobile_beads == 60);
  CHECK(built.cadence.duration_s == 0.16);
  REQUIRE(built.camera.has_value());
  CHECK(built.camera->fps == 25.0);

  // The vane's drive and the world's options as values.
  SceneSpec changed = spec;
  changed.vane.phi0_rad = 0.1;
  changed.sim.tolerance = 1e-4;
  const LoadedScene c = build_scene(changed, true);  // the container, the vane's beads, no fill
  REQUIRE(c.world.has_value());
  CHECK(c.world->options().tolerance == 1e-4);
  CHECK(c.world->body_count() < loaded.world->body_count());  // no mobile bead placed
  const LoadedScene d = build_scene(changed, false);
  REQUIRE(d.world->rotor_count() == 1);
  CHECK(d.world->rotor(0).phi0 == 0.1);
  CHECK(d.world->state_hash() != loaded.world->state_hash());
}

TEST_CASE("a scene spec written as a file reads back as the same spec and builds the same world",
          "[sim][scene]") {
  SceneSpec spec = read_scene(kFilmedCup);
  // Values a file spells with care: a string, a list, exponents, many digits, positions.
  spec.sim.sweep_order = "alternate";
  spec.sim.gravity_m_per_s2 = SceneSpec::Numbers{0.0, 0.0, -9.81};
  spec.chains.l_max_m = 4e-4;
  spec.chains.max_angle_deg = 1.0 / 3.0 * 100.0;
  spec.fill.seed = 7;
  // Four fixed beads above the drop column, between two blades (a list of three lines).
  spec.beads.fixed_positions_m = SceneSpec::Numbers{0.006, 0.006, 0.019, 0.009, 0.009, 0.019,
                                                    0.012, 0.012, 0.019, 0.015, 0.0, 0.019};
  spec.fill.height_d = 3.5;  // a length in bead diameters stays one
  std::ostringstream text;
  write_scene(spec, text, "# a test scene\n");
  const std::filesystem::path file = std::filesystem::temp_directory_path() / "shearzone_test_scene_roundtrip.toml";
  {
    std::ofstream f(file);
    f << text.str();
  }
  const SceneSpec back = read_scene(file);
  std::filesystem::remove(file);
  CHECK(text.str().rfind("# a test scene\n[sim]\nduration_s = 0.16\n", 0) == 0);
  CHECK(same_keys(spec, back));
  CHECK(back.fill.height_d == 3.5);
  CHECK_FALSE(back.fill.height_m.has_value());
  CHECK(build_scene(back, false).world->state_hash() == build_scene(spec, false).world->state_hash());

  // A string the file must escape (a quote, a backslash, a tab) reads back as written;
  // build_scene then refuses the value by name.
  spec.sim.sweep_order = "for\"ward\\ \t";
  std::ostringstream escaped;
  write_scene(spec, escaped);
  {
    std::ofstream f(file);
    f << escaped.str();
  }
  const SceneSpec odd = read_scene(file);
  std::filesystem::remove(file);
  CHECK(odd.sim.sweep_order == spec.sim.sweep_order);
  CHECK_THROWS_WITH(build_scene(odd, true), Catch::Contains("key \"sim.sweep_order\""));
}

TEST_CASE("a scene spec built in code is refused as a file is, naming its source and key", "[sim][scene]") {
  SceneSpec spec;
  spec.source = "the test's cup";
  spec.sim.duration_s = 0.1;
  spec.cylinder.radius_m = -0.02;
  spec.cylinder.height_m = 0.02;
  spec.beads.diameter_m = 0.004;
  try {
    (void)build_scene(spec, true);
    FAIL("a negative radius was accepted");
  } catch (const ConfigError& e) {
    CHECK(std::string(e.what()) == "the test's cup: key \"cylinder.radius_m\": -0.02 (expected > 0)");
  }
  // Built as values, the spec may hold what no file can: refused by name.
  spec.cylinder.radius_m = 0.024;
  spec.sim.gravity_m_per_s2 = SceneSpec::Numbers{0.0, 0.0, std::numeric_limits<double>::quiet_NaN()};
  CHECK_THROWS_WITH(build_scene(spec, true),
                    Catch::Contains("key \"sim.gravity_m_per_s2\": nan is not a finite number"));
  spec.sim.gravity_m_per_s2.reset();
  CHECK(build_scene(spec, true).world->body_count() > 0);  // the cylinder's beads
}
