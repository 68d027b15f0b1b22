// libFuzzer target: tracks files (`piv --method track --tracks tracks.h5`) read back.
#include "fuzz_util.hpp"
#include "shearzone/core/error.hpp"
#include "shearzone/io/track_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace shearzone;
  const auto path = fuzz::write_temp(data, size, ".h5");
  try {
    std::string options;
    (void)io::read_track_file(path, &options);
  } catch (const Error&) {
  }
  return 0;
}
