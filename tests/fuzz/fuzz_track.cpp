// libFuzzer target: the tracker (track/track.hpp) on arbitrary pixels. The first bytes
// choose the frame size (8..71 px a side), the bead diameter (3..66 px) and whether
// masks are used (what hides beads, and the region outside which none counts); the
// rest fills frame a, frame b and the masks (repeated as needed).
// Detection, Lucas-Kanade, the grid and the linker must never crash, hang or read out
// of bounds, whatever the frames hold.
#include <opencv2/core.hpp>

#include "fuzz_util.hpp"
#include "shearzone/core/error.hpp"
#include "shearzone/track/track.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace shearzone;
  if (size < 5) return 0;
  const int w = 8 + data[0] % 64, h = 8 + data[1] % 64;
  const double d = 3 + data[2] % 64;
  const bool masked = data[3] & 1, region = data[3] & 2;
  const std::uint8_t* px = data + 4;
  const std::size_t n = size - 4;
  auto fill = [&](cv::Mat& m, std::size_t offset) {
    for (int i = 0; i < m.rows; ++i)
      for (int j = 0; j < m.cols; ++j)
        m.at<std::uint8_t>(i, j) = px[(offset + static_cast<std::size_t>(i * m.cols + j)) % n];
  };
  cv::Mat a(h, w, CV_8U), b(h, w, CV_8U), mask, outside;
  fill(a, 0);
  fill(b, static_cast<std::size_t>(w * h));
  if (masked) {
    mask.create(h, w, CV_8U);
    fill(mask, static_cast<std::size_t>(2 * w * h));
    mask.setTo(0, mask < 200);
  }
  if (region) {
    outside.create(h, w, CV_8U);
    fill(outside, static_cast<std::size_t>(3 * w * h));
    outside.setTo(0, outside < 128);
  }
  try {
    track::TrackOptions o;
    o.bead_diameter_px = d;
    o.centre_offset_px = track::disc_centre_offset(a, mask, o);  // as piv does on a clip's first frame
    const track::PairBeads p = track::track_pair(a, b, mask, mask, o, outside);
    (void)track::beads_to_grid(p, a.size(), track::grid_cell_px(d), mask);
    (void)track::detect_beads(a, cv::Mat(), o, outside);
    track::Linker linker(d);
    (void)linker.link(p, 0, 1, 0.0, 0.04);
    (void)linker.link(p, 1, 2, 0.04, 0.04);
  } catch (const Error&) {
  }
  return 0;
}
