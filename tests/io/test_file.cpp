#include <catch2/catch.hpp>

#include <cmath>
#include <limits>

#include "shearzone/io/csv.hpp"
#include "shearzone/io/file.hpp"

namespace io = shearzone::io;

TEST_CASE("has_extension compares the extension without regard to case", "[io]") {
  CHECK(io::has_extension("a/b.csv", ".csv"));
  CHECK(io::has_extension("a/B.CSV", ".csv"));
  CHECK(io::has_extension("clip.Mp4", ".MP4"));
  CHECK_FALSE(io::has_extension("a/b.csv.h5", ".csv"));
  CHECK_FALSE(io::has_extension("a/b.csvx", ".csv"));
  CHECK_FALSE(io::has_extension("a/csv", ".csv"));
  CHECK(io::has_extension("a/b", ""));
}

TEST_CASE("format_number and its empty-cell variants", "[io]") {
  const double inf = std::numeric_limits<double>::infinity();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  CHECK(io::format_number(0.1) == "0.1");
  CHECK(io::format_number(0.1) == io::CsvWriter::format_number(0.1));
  CHECK(io::format_number(nan) == "nan");
  CHECK(io::format_number(-inf) == "-inf");
  CHECK(io::format_number_or_empty(2.25) == "2.25");
  CHECK(io::format_number_or_empty(nan).empty());
  CHECK(io::format_number_or_empty(inf).empty());
  CHECK(io::format_number_nan_empty(2.25) == "2.25");
  CHECK(io::format_number_nan_empty(nan).empty());
  CHECK(io::format_number_nan_empty(inf) == "inf");
}
