// libFuzzer target: TOML configs and scenes (io::TomlConfig, used by every --config
// and by `shearzone sim`).
#include <string>

#include "fuzz_util.hpp"
#include "shearzone/core/error.hpp"
#include "shearzone/io/toml_config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace shearzone;
  try {
    (void)io::TomlConfig::parse(std::string(reinterpret_cast<const char*>(data), size), "fuzz.toml");
  } catch (const Error&) {
  }
  return 0;
}
