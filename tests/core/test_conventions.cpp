#include <catch2/catch.hpp>

#include "shearzone/core/conventions.hpp"
#include "shearzone/core/metadata.hpp"
#include "shearzone/core/version.hpp"

using namespace shearzone::core;

// Exact arithmetic on small integers and one hypot: a few ulp.
constexpr double kExact = 1e-12;

TEST_CASE("a solid rotation with omega > 0 has v_theta = omega r and v_r = 0", "[core]") {
  const double xc = 10, yc = 20, omega = 0.1;
  for (double x : {3.0, 10.0, 17.5}) {
    for (double y : {5.0, 27.0}) {
      const double u = omega * (y - yc), v = -omega * (x - xc);
      const auto p = polar_from_cartesian(x, y, u, v, xc, yc);
      const double r = std::hypot(x - xc, y - yc);
      CHECK(p.v_theta == Approx(omega * r).margin(kExact));
      CHECK(p.v_r == Approx(0.0).margin(kExact));
    }
  }
}

TEST_CASE("counter-clockwise on screen moves a point right of the centre upwards (v < 0)",
          "[core]") {
  // Worked example from conventions.hpp: centre (10, 10), point (13, 10), omega 0.1.
  const auto [u, v] = cartesian_from_azimuthal(13, 10, 0.3, 10, 10);
  CHECK(u == Approx(0.0).margin(kExact));
  CHECK(v == Approx(-0.3).margin(kExact));
  const auto p = polar_from_cartesian(13, 10, u, v, 10, 10);
  CHECK(p.v_theta == Approx(0.3).margin(kExact));
}

TEST_CASE("an outward displacement is a positive v_r", "[core]") {
  const auto p = polar_from_cartesian(10, 14, 0.0, 2.0, 10, 10);  // below the centre, moving down
  CHECK(p.v_r == Approx(2.0).margin(kExact));
  CHECK(p.v_theta == Approx(0.0).margin(kExact));
}

TEST_CASE("polar decomposition at the centre itself is zero, not NaN", "[core]") {
  const auto p = polar_from_cartesian(5, 5, 1.0, 1.0, 5, 5);
  CHECK(p.v_r == 0.0);
  CHECK(p.v_theta == 0.0);
}

TEST_CASE("image_direction measures angles counter-clockwise on screen", "[core]") {
  const auto [ex, ey] = image_direction(M_PI / 2);
  CHECK(ex == Approx(0.0).margin(kExact));
  CHECK(ey == Approx(-1.0).margin(kExact));  // up on screen is -y
}

TEST_CASE("standard metadata carries tool, version, command line and conventions", "[core]") {
  const Metadata m = standard_metadata("shearzone synth particles -o d");
  CHECK(metadata_value(m, "tool") == "shearzone");
  CHECK(metadata_value(m, "version") == shearzone::kVersion);
  CHECK(metadata_value(m, "command_line") == "shearzone synth particles -o d");
  CHECK(metadata_value(m, "convention_image_axes").find("(x, y) = (j, i)") != std::string::npos);
  CHECK(metadata_value(m, "convention_rotation").find("counter-clockwise") != std::string::npos);
}

TEST_CASE("command_line_from_argv quotes arguments a shell would split", "[core]") {
  const char* argv[] = {"shearzone", "synth", "-o", "my dir", "it's"};
  CHECK(command_line_from_argv(5, argv) == "shearzone synth -o 'my dir' 'it'\\''s'");
}
