#include <cstdio>

#include <catch2/catch.hpp>

#include "shearzone/core/progress.hpp"

using shearzone::core::LogLevel;
using shearzone::core::ProgressReporter;

TEST_CASE("progress line shows items, rate and ETA", "[core]") {
  CHECK(ProgressReporter::format_line("piv", 25, 100, 5.0) == "piv: 25/100 (5.0/s, ETA 15 s)");
  CHECK(ProgressReporter::format_line("piv", 10, 10000, 1.0) ==
        "piv: 10/10000 (10.0/s, ETA 16.6 min)");
  CHECK(ProgressReporter::format_line("piv", 0, 10, 0.0) == "piv: 0/10 (0.0/s, ETA ?)");
  CHECK(ProgressReporter::format_line("read", 7, 0, 2.0) == "read: 7 (3.5/s)");
}

TEST_CASE("progress stays quiet when its stream is not a terminal", "[core]") {
  std::FILE* f = std::tmpfile();
  REQUIRE(f != nullptr);
  {
    ProgressReporter p("work", LogLevel::kNormal, f, 0.0);
    CHECK_FALSE(p.enabled());
    auto cb = p.callback();
    for (std::size_t i = 0; i <= 10; ++i) cb(i, 10);
  }
  CHECK(std::ftell(f) == 0);  // nothing was written
  std::fclose(f);
}

TEST_CASE("progress is off in quiet mode", "[core]") {
  ProgressReporter p("work", LogLevel::kQuiet, stderr);
  CHECK_FALSE(p.enabled());
}
