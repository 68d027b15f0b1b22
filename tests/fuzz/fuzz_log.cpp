// libFuzzer target: rheometer logs of every format (auto-detected: Anton Paar, TRIOS,
// RepTate, generic CSV/TSV; UTF-8, UTF-16, Latin-1).
#include "fuzz_util.hpp"
#include "shearzone/core/error.hpp"
#include "shearzone/io/oscillation_log.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace shearzone;
  const auto path = fuzz::write_temp(data, size, ".csv");
  try {
    (void)io::read_oscillation_log(path);
  } catch (const Error&) {
  }
  return 0;
}
