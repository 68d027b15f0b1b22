// libFuzzer target: field files (fields.h5 of `shearzone piv`) through the profile
// job, and the profile CSV read back by the width job.
#include "fuzz_util.hpp"
#include "shearzone/core/error.hpp"
#include "shearzone/pipeline/profile_job.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace shearzone;
  const auto path = fuzz::write_temp(data, size, ".h5");
  pipeline::ProfileJobOptions o;
  o.input = path;
  o.output = fuzz::temp_path("-profile.csv");
  o.force = true;
  o.centre_x_px = o.centre_y_px = 64;
  o.vane_radius_px = 8;
  o.cup_radius_px = 60;
  o.m_per_px = 1e-4;
  o.bin_px = 8;
  o.scale_from = "m-per-px";
  try {
    (void)pipeline::run_profile_job(o, {});
  } catch (const Error&) {
  }
  return 0;
}
