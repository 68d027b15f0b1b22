#include <fstream>
#include <sstream>

#include <catch2/catch.hpp>

#include "shearzone/core/error.hpp"
#include "shearzone/io/angle_log.hpp"
#include "shearzone/io/csv.hpp"
#include "support/temp_dir.hpp"

using namespace shearzone;
using Catch::Matchers::Contains;

namespace {
/// Expects parse_csv(text) to throw InputError whose message contains `fragment`.
void expect_error(const std::string& text, const std::string& fragment) {
  try {
    io::parse_csv(text, "f.csv");
    FAIL("expected InputError containing: " << fragment);
  } catch (const InputError& e) {
    CHECK_THAT(e.what(), Contains(fragment));
  }
}
}  // namespace

TEST_CASE("CSV round trip keeps metadata, quoting and exact numbers", "[io][csv]") {
  std::ostringstream out;
  {
    io::CsvWriter w(out, {{"tool", "shearzone"}, {"note", "two\nlines"}},
                    {"label", "x_px", "u_px"});
    w.row(std::vector<std::string>{"plain", "1", "2"});
    w.row(std::vector<std::string>{"with, comma", "3", "4"});
    w.row(std::vector<std::string>{"say \"hi\"", "5", "6"});
    w.row(std::vector<std::string>{"multi\nline", "7", "8"});
    w.row(std::vector<double>{0.1, 1.0 / 3.0, -2.5e-300});
  }
  const std::string text = out.str();
  CHECK_THAT(text, Contains("\"with, comma\""));
  CHECK_THAT(text, Contains("\"say \"\"hi\"\"\""));
  CHECK_THAT(text, Contains("# note: two lines"));  // metadata stays on one line

  const io::CsvTable t = io::parse_csv(text, "mem.csv");
  REQUIRE(t.columns == std::vector<std::string>{"label", "x_px", "u_px"});
  REQUIRE(t.num_rows() == 5);
  CHECK(core::metadata_value(t.metadata, "tool") == "shearzone");
  CHECK(t.rows[1][0] == "with, comma");
  CHECK(t.rows[2][0] == "say \"hi\"");
  CHECK(t.rows[3][0] == "multi\nline");
  // Shortest round-trip formatting reads back bit-exactly.
  CHECK(t.number(4, 0) == 0.1);
  CHECK(t.number(4, 1) == 1.0 / 3.0);
  CHECK(t.number(4, 2) == -2.5e-300);
  // The row after a quoted line break knows its true line number.
  CHECK(t.row_lines[4] == t.row_lines[3] + 2);
}

TEST_CASE("CSV reader accepts BOM, CRLF, semicolons with decimal commas, and tabs",
          "[io][csv]") {
  const std::string bom = "\xEF\xBB\xBF";
  SECTION("BOM and CRLF") {
    const auto t = io::parse_csv(bom + "# unit: s\r\nt_s,x_m\r\n0,1.5\r\n1,2.5\r\n", "a.csv");
    CHECK(t.columns[0] == "t_s");
    CHECK(t.numeric_column("x_m") == std::vector<double>{1.5, 2.5});
  }
  SECTION("semicolon separator with decimal commas (spreadsheet export)") {
    const auto t = io::parse_csv("t_s;torque_N_m\n0,5;1,25e-3\n1;-2,0\n", "b.csv");
    CHECK(t.separator == ';');
    CHECK(t.numeric_column("t_s") == std::vector<double>{0.5, 1.0});
    CHECK(t.numeric_column("torque_N_m") == std::vector<double>{1.25e-3, -2.0});
  }
  SECTION("tab separator") {
    const auto t = io::parse_csv("a\tb\n1\t2\n\n3\t4\n", "c.tsv");
    CHECK(t.separator == '\t');
    CHECK(t.numeric_column("b") == std::vector<double>{2, 4});
  }
}

TEST_CASE("CSV errors name the file and the line", "[io][csv]") {
  expect_error("a,b\n1,2\n3\n", "f.csv:3: row has 1 field; expected 2");
  expect_error("a,b\n1,\"unterminated\n", "f.csv:2: unterminated quoted field");
  expect_error("a,b\n1,x\"y\n", "f.csv:2: stray '\"'");
  expect_error("# only comments\n\n", "f.csv: no header row");
  expect_error("a,a\n1,2\n", "f.csv:1: column name \"a\" appears twice");
  expect_error("a,\n1,2\n", "f.csv:1: column 2 of the header row has no name");

  const auto t = io::parse_csv("# c\nt_s,x_m\n0,1\n1,abc\n2,nan\n3,\n", "g.csv");
  CHECK_THROWS_WITH(t.numeric_column("x_m"), Contains("g.csv:4: column \"x_m\": \"abc\" is not a number"));
  CHECK_THROWS_WITH(t.number(2, 1), Contains("g.csv:5: column \"x_m\": \"nan\" is not a finite number"));
  CHECK_THROWS_WITH(t.number(3, 1), Contains("g.csv:6: column \"x_m\": empty cell"));
  CHECK_THROWS_WITH(t.column_index("y_m"),
                    Contains("g.csv:2: missing column \"y_m\"; the header has: t_s, x_m"));
}

TEST_CASE("read_csv names a missing file", "[io][csv]") {
  CHECK_THROWS_WITH(io::read_csv("/nonexistent/x.csv"), Contains("/nonexistent/x.csv: no such file"));
}

TEST_CASE("read_csv reads a file from disk", "[io][csv]") {
  testing::TempDir dir("csv");
  testing::write_file(dir / "a.csv", "x_px,y_px\n1,2\n");
  const auto t = io::read_csv(dir / "a.csv");
  CHECK(t.source == (dir / "a.csv").string());
  CHECK(t.number(0, 1) == 2.0);
}

// A 10 MB header was echoed back in a 10 MB error line (and checked for duplicate
// names in quadratic time): messages quote a bounded excerpt, parsing stays linear.
TEST_CASE("a huge header gives a short message", "[io][csv]") {
  std::string header, row;
  for (int i = 0; i < 200000; ++i) {
    header += (i ? ",c" : "c") + std::to_string(i);
    row += i ? ",1" : "1";
  }
  const auto t = io::parse_csv(header + "\n" + row + "\n", "wide.csv");
  REQUIRE(t.columns.size() == 200000);
  try {
    (void)t.column_index("phi");
    FAIL("expected an InputError");
  } catch (const InputError& e) {
    const std::string m = e.what();
    CHECK(m.find("wide.csv:1: missing column \"phi\"; the header has: c0, c1,") == 0);
    CHECK(m.find("more characters)") != std::string::npos);
    CHECK(m.size() < 500);
  }
  CHECK(io::excerpt(std::string(1000, 'x'), 10) == "xxxxxxxxxx... (990 more characters)");
}

TEST_CASE("an angle log written by write_angle_log reads back exactly, a log whose time does not increase is "
          "refused with its line",
          "[io]") {
  testing::TempDir tmp("angle_log");
  const io::AngleLog log{{0.0, 0.04, 0.08, 0.12}, {0.0, 0.1 / 3.0, -2e-17, 0.3}};
  {
    std::ofstream f(tmp / "a.csv");
    io::write_angle_log(f, {{"source", "test"}}, log);
  }
  const io::AngleLog back = io::read_angle_log((tmp / "a.csv").string(), 4);
  CHECK(back.time_s == log.time_s);  // every digit: exact
  CHECK(back.angle_rad == log.angle_rad);
  CHECK_THROWS_AS(io::read_angle_log((tmp / "a.csv").string(), 5), InputError);
  testing::write_file(tmp / "b.csv", "time_s,angle_rad\n0,0\n0.1,0\n0.1,0\n");
  CHECK_THROWS_WITH(io::read_angle_log((tmp / "b.csv").string(), 2),
                    Catch::Matchers::Contains("b.csv:4") && Catch::Matchers::Contains("does not increase"));
}
