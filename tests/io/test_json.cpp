#include <catch2/catch.hpp>

#include <limits>

#include "shearzone/io/json.hpp"

using namespace shearzone;

TEST_CASE("JSON strings escape quotes, backslashes and control characters, NaN is null", "[io][json]") {
  CHECK(io::json_string("plain") == "\"plain\"");
  CHECK(io::json_string("run \"a\" \\ b") == "\"run \\\"a\\\" \\\\ b\"");
  CHECK(io::json_string("tab\tline\nret\r\x01") == "\"tab\\tline\\nret\\r\\u0001\"");
  CHECK(io::json_string("µm") == "\"µm\"");  // UTF-8 passes through
  CHECK(io::json_number(0.1) == "0.1");
  CHECK(io::json_number(std::numeric_limits<double>::quiet_NaN()) == "null");
  CHECK(io::json_number(std::numeric_limits<double>::infinity()) == "null");
  CHECK(io::json_list({"a", "b\""}) == "[\"a\", \"b\\\"\"]");
  CHECK(io::json_list({}) == "[]");
}
