// libFuzzer target: still images (every format read, by content).
#include <string>

#include "fuzz_util.hpp"
#include "shearzone/core/error.hpp"
#include "shearzone/io/image.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace shearzone;
  try {
    int bits = 0;
    (void)io::decode_image_gray(std::string(reinterpret_cast<const char*>(data), size), "fuzz.img", &bits);
  } catch (const Error&) {
  }
  return 0;
}
