#include <catch2/catch.hpp>

#include "shearzone/core/error.hpp"
#include "shearzone/io/toml_config.hpp"
#include "support/temp_dir.hpp"

using namespace shearzone;
using Catch::Matchers::Contains;

TEST_CASE("TOML values read back with their types", "[io][toml]") {
  const auto cfg = io::TomlConfig::parse(
      "width = 640\nnoise = 0.02\nfield = \"rotation\"\nforce = true\ncentre = [320, 240.5]\n"
      "[vane]\nblades = 4\n",
      "c.toml");
  CHECK(cfg.keys() == std::vector<std::string>{"centre", "field", "force", "noise", "vane.blades",
                                               "width"});
  CHECK(cfg.get_int("width") == 640);
  CHECK(cfg.get_double("width") == 640.0);
  CHECK(cfg.get_double("noise") == 0.02);
  CHECK(cfg.get_string("field") == "rotation");
  CHECK(cfg.get_bool("force"));
  CHECK(cfg.is_array("centre"));
  CHECK(cfg.texts("centre") == std::vector<std::string>{"320", "240.5"});
  CHECK(cfg.line("field") == 3);
}

TEST_CASE("an unknown TOML key is a ConfigError naming the key, file and line", "[io][toml]") {
  const auto cfg = io::TomlConfig::parse("width = 1\nwidht = 2\n", "c.toml");
  CHECK_THROWS_MATCHES(cfg.require_known({"width", "height"}), ConfigError,
                       Catch::Matchers::Predicate<ConfigError>([](const ConfigError& e) {
                         const std::string m = e.what();
                         return m.find("c.toml:2: unknown key \"widht\"") != std::string::npos &&
                                m.find("did you mean \"width\"") != std::string::npos &&
                                m.find("expected one of: height, width") != std::string::npos;
                       }));
  CHECK_NOTHROW(cfg.require_known({"width", "widht"}));
}

TEST_CASE("a TOML type mismatch names the key and the expected type", "[io][toml]") {
  const auto cfg = io::TomlConfig::parse("width = \"wide\"\n", "c.toml");
  CHECK_THROWS_WITH(cfg.get_double("width"),
                    Contains("c.toml:1: key \"width\"") && Contains("expected a number"));
}

TEST_CASE("a TOML syntax error is a ConfigError with the line", "[io][toml]") {
  CHECK_THROWS_MATCHES(io::TomlConfig::parse("a = 1\nb = = 2\n", "bad.toml"), ConfigError,
                       Catch::Matchers::Predicate<ConfigError>([](const ConfigError& e) {
                         return std::string(e.what()).rfind("bad.toml:2: TOML syntax error", 0) == 0;
                       }));
}

TEST_CASE("a missing TOML file is an InputError naming the path", "[io][toml]") {
  CHECK_THROWS_MATCHES(io::TomlConfig::load("/no/such/cfg.toml"), InputError,
                       Catch::Matchers::Predicate<InputError>([](const InputError& e) {
                         return std::string(e.what()).find("/no/such/cfg.toml") != std::string::npos;
                       }));
}

TEST_CASE("TOML loads from a file", "[io][toml]") {
  testing::TempDir dir("toml");
  testing::write_file(dir / "c.toml", "\xEF\xBB\xBFseed = 7\r\n");
  CHECK(io::TomlConfig::load(dir / "c.toml").get_int("seed") == 7);
}

// 10 000 nested arrays or inline tables overflowed the parser's stack (SIGSEGV):
// refused on the raw text before parsing. Brackets in strings and comments do not count.
TEST_CASE("deeply nested TOML is refused before the parser recurses", "[io][toml]") {
  const std::string deep_arrays = "a = " + std::string(10000, '[') + std::string(10000, ']') + "\n";
  std::string deep_tables = "a = ";
  for (int i = 0; i < 10000; ++i) deep_tables += "{b=";
  deep_tables += "1" + std::string(10000, '}') + "\n";
  for (const auto& text : {deep_arrays, deep_tables})
    CHECK_THROWS_WITH(io::TomlConfig::parse("x = 1\n" + text, "deep.toml"),
                      Catch::Contains("deep.toml:2: arrays or inline tables nested deeper than 64 levels"));
  const std::string quoted = "s = \"" + std::string(200, '[') + "\"\nt = '''" + std::string(200, '{') +
                             "'''\n# " + std::string(200, '[') + "\nu = [1, 2]\n";
  CHECK_NOTHROW(io::TomlConfig::parse(quoted, "ok.toml"));
}

TEST_CASE("a number list and a key's refusal come from one place", "[io][toml]") {
  const auto c = io::TomlConfig::parse("a = [1, 2.5, -3e-2]\nb = 4\nc = [\"x\"]\nd = []\n", "t.toml");
  CHECK(c.get_doubles("a") == std::vector<double>{1, 2.5, -3e-2});
  CHECK(c.get_doubles("b") == std::vector<double>{4});
  CHECK(c.get_doubles("d").empty());
  CHECK_THROWS_WITH(c.get_doubles("c"),
                    "t.toml:3: key \"c\": \"x\" is not a finite number (expected a number or a list of numbers)");
  CHECK_THROWS_WITH(c.fail("b", "4 (expected 5)"), "t.toml:2: key \"b\": 4 (expected 5)");
}
