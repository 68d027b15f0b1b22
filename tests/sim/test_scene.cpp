// The scene file as values (sim/scene.hpp): read_scene then build_scene is load_scene,
// and a spec changed as a value builds what it says.
#include <filesystem>

#include <catch2/catch.hpp>

#include "shearzone/sim/scene.hpp"

using namespace shearzone::sim;

namespace {
const std::filesystem::path kFilmedCup =
    std::filesystem::path(SHEARZONE_DATA_SAMPLES_DIR) / "sim" / "filmed_cup.toml";
}  // namespace

TEST_CASE("a scene read into a spec and built is the world load_scene builds, and a spec changed as a value "
          "builds the change",
          "[sim][scene]") {
  const SceneSpec spec = read_scene(kFilmedCup);
  REQUIRE(spec.camera.has_value());
  CHECK(spec.camera->fps == 25.0);
  CHECK(spec.cadence.duration_s == 0.16);
  CHECK(spec.options.time_step == 1e-3);
  CHECK(spec.bodies.cylinder);
  CHECK(spec.bodies.chains.chains == 60);
  CHECK_FALSE(spec.bodies.vane.empty());

  const LoadedScene loaded = load_scene(kFilmedCup, false);
  const LoadedScene built = build_scene(spec, false);
  REQUIRE(loaded.world.has_value());
  REQUIRE(built.world.has_value());
  CHECK(built.world->state_hash() == loaded.world->state_hash());
  CHECK(built.chain_ids == loaded.chain_ids);
  CHECK(built.mobile_beads == 60);
  CHECK(built.cadence.duration_s == spec.cadence.duration_s);

  // The vane's drive and the world's options as values.
  SceneSpec changed = spec;
  changed.bodies.vane_phi0 = 0.1;
  changed.options.tolerance = 1e-4;
  const LoadedScene c = build_scene(changed, true);  // the container, the vane's beads, no fill
  REQUIRE(c.world.has_value());
  CHECK(c.world->options().tolerance == 1e-4);
  CHECK(c.world->body_count() < loaded.world->body_count());  // no mobile bead placed
  const LoadedScene d = build_scene(changed, false);
  REQUIRE(d.world->rotor_count() == 1);
  CHECK(d.world->rotor(0).phi0 == 0.1);
  CHECK(d.world->state_hash() != loaded.world->state_hash());
}
