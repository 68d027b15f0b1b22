// The grouped table reader (io/grouped_table.hpp) that `fit` and `collapse erf` read.
#include <cmath>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "shearzone/core/error.hpp"
#include "shearzone/io/grouped_table.hpp"
#include "support/temp_dir.hpp"

using namespace shearzone;
using Catch::Matchers::Contains;
using shearzone::testing::TempDir;
using shearzone::testing::write_file;

TEST_CASE("grouped table: numeric groups within the tolerance are one, labelled by their mean", "[io][grouped]") {
  TempDir t("grouped_numeric");
  // N = 9 written three ways (a study's tags), 45 once; a row not ok is skipped.
  write_file(t / "w.csv",
             "# a header line\nphi0_rad,rc_m,rc_se_m,N,rc_status\n"
             "0.1,0.010,0.001,9,ok\n0.2,0.012,0.002,9.0000000001,ok\n0.3,0.015,0.001,45,ok\n"
             "0.4,0.020,0.001,8.9999999999,ok\n0.5,0.030,0.001,45,noise_limited\n");
  const io::GroupedData g = io::read_grouped(t / "w.csv", "phi0_rad", "rc_m", "rc_se_m", "N", 1e-6);
  REQUIRE(g.labels == std::vector<std::string>{"9", "45"});
  CHECK(g.group_values[0] == Approx(9.0).epsilon(1e-12));
  CHECK(g.x[0] == std::vector<double>{0.1, 0.2, 0.4});
  CHECK(g.y[1] == std::vector<double>{0.015});
  CHECK(g.sigma[0] == std::vector<double>{0.001, 0.002, 0.001});
  CHECK(g.skipped_rows == 1);
  CHECK(g.x_unit == "rad");
  CHECK(g.y_unit == "m");
  // A tolerance of 0 splits the three nines.
  CHECK(io::read_grouped(t / "w.csv", "phi0_rad", "rc_m", "", "N", 0.0).labels.size() == 4);
  // No group column: one group, "all", no sigma.
  const io::GroupedData all = io::read_grouped(t / "w.csv", "phi0_rad", "rc_m", "", "", 1e-6);
  REQUIRE(all.labels == std::vector<std::string>{"all"});
  CHECK(all.x[0].size() == 4);
  CHECK(all.sigma[0].empty());
}

TEST_CASE("grouped table: text groups keep their order, bad rows are refused with file and line", "[io][grouped]") {
  TempDir t("grouped_text");
  write_file(t / "a.csv", "x_s,y_m,label\n1,2,spaghetti\n2,3,steel\n3,4,spaghetti\n");
  const io::GroupedData g = io::read_grouped(t / "a.csv", "x_s", "y_m", "", "label", 1e-6);
  REQUIRE(g.labels == std::vector<std::string>{"spaghetti", "steel"});
  CHECK(std::isnan(g.group_values[0]));
  CHECK(g.x[0] == std::vector<double>{1, 3});

  write_file(t / "s.csv", "x_s,y_m,s_m\n1,2,0.1\n2,3,0\n");
  CHECK_THROWS_WITH(io::read_grouped(t / "s.csv", "x_s", "y_m", "s_m", "", 1e-6),
                    Contains("s.csv:3: column \"s_m\": 0 is not a positive uncertainty"));
  write_file(t / "e.csv", "x_s,y_m,label\n1,2,\n");
  CHECK_THROWS_WITH(io::read_grouped(t / "e.csv", "x_s", "y_m", "", "label", 1e-6),
                    Contains("e.csv:2: column \"label\": empty group value"));
  write_file(t / "n.csv", "x_s,y_m,status\n1,2,failed\n");
  CHECK_THROWS_WITH(io::read_grouped(t / "n.csv", "x_s", "y_m", "", "", 1e-6),
                    Contains("n.csv:1: no row has status \"ok\""));
  write_file(t / "h.csv", "x_s,y_m\n");
  CHECK_THROWS_AS(io::read_grouped(t / "h.csv", "x_s", "y_m", "", "", 1e-6), InputError);
}
