// libFuzzer target: video containers and their headers (the first frames decoded).
#include <opencv2/core.hpp>

#include "fuzz_util.hpp"
#include "shearzone/core/error.hpp"
#include "shearzone/io/video.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace shearzone;
  const auto path = fuzz::write_temp(data, size, ".mp4");
  try {
    io::VideoReader r(path);
    cv::Mat grey;
    double t = 0;
    for (int k = 0; k < 3 && r.read(grey, t); ++k) {
    }
  } catch (const Error&) {
  }
  return 0;
}
