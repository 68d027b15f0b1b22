// libFuzzer target: profile CSVs (and no groups file) through the width job.
#include "fuzz_util.hpp"
#include "shearzone/core/error.hpp"
#include "shearzone/pipeline/width_job.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace shearzone;
  pipeline::WidthJobOptions o;
  o.inputs = {fuzz::write_temp(data, size, ".csv")};
  o.output = fuzz::temp_path("-widths.csv");
  o.force = true;
  o.width.bootstrap = 50;
  try {
    (void)pipeline::run_width_job(o, {});
  } catch (const Error&) {
  }
  return 0;
}
