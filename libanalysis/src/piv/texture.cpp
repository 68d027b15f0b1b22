#include "shearzone/piv/texture.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <opencv2/core.hpp>

#include "shearzone/piv/piv.hpp"

namespace shearzone::piv {

double texture_half_width_px(const cv::Mat& image, const cv::Mat& mask) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  if (image.empty() || image.channels() != 1) return kNaN;
  const cv::Mat f = to_unit_float(image);
  cv::Mat m(f.size(), CV_32F, cv::Scalar(1.0f));  // 1 where the pixel counts
  if (!mask.empty()) m.setTo(0.0f, mask != 0);
  // Tiles of kTile px (the whole image if smaller), each correlated with zero padding
  // (linear, not circular); their products and pair counts are summed: a 1080p frame
  // costs a few ms instead of a 3840 x 2160 transform.
  constexpr int kTile = 256;
  constexpr std::size_t kMaxTiles = 6;
  std::vector<cv::Rect> tiles;
  if (f.rows < kTile || f.cols < kTile) {
    tiles.emplace_back(0, 0, f.cols, f.rows);
  } else {
    // Tiles at half-tile steps; the kMaxTiles with the most unmasked pixels (at least a
    // quarter of the tile: a cup's annulus between vane and wall), overlapping by at most
    // half a tile, in scan order among equals.
    std::vector<std::pair<double, cv::Rect>> all;
    for (int y = 0; y + kTile <= f.rows; y += kTile / 2)
      for (int x = 0; x + kTile <= f.cols; x += kTile / 2) {
        const cv::Rect r(x, y, kTile, kTile);
        const double un = cv::sum(m(r))[0];
        if (un >= 0.25 * kTile * kTile) all.emplace_back(un, r);
      }
    std::stable_sort(all.begin(), all.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
    for (const auto& [un, r] : all) {
      if (tiles.size() == kMaxTiles) break;
      bool overlaps = false;
      for (const cv::Rect& t : tiles) overlaps |= (t & r).area() > kTile * kTile / 2;
      if (!overlaps) tiles.push_back(r);
    }
  }
  if (tiles.empty()) return kNaN;
  const int th = tiles.front().height, tw = tiles.front().width;
  const int h = cv::getOptimalDFTSize(2 * th), w = cv::getOptimalDFTSize(2 * tw);
  auto autocorr = [&](const cv::Mat& x) {
    cv::Mat p = cv::Mat::zeros(h, w, CV_32F), spec, out;
    x.copyTo(p(cv::Rect(0, 0, x.cols, x.rows)));
    cv::dft(p, spec, cv::DFT_COMPLEX_OUTPUT);
    cv::mulSpectrums(spec, spec, spec, 0, true);
    cv::idft(spec, out, cv::DFT_REAL_OUTPUT | cv::DFT_SCALE);
    return out;
  };
  cv::Mat az = cv::Mat::zeros(h, w, CV_32F), am = cv::Mat::zeros(h, w, CV_32F);
  double n = 0;
  cv::Mat full_pairs;  // pair counts of a tile without masked pixels (the same for each)
  for (const cv::Rect& r : tiles) {
    const cv::Mat ft = f(r), mt = m(r);
    const double nt = cv::sum(mt)[0];
    if (!(nt > 16)) continue;
    const double mean = cv::sum(ft.mul(mt))[0] / nt;  // each tile's own mean (slow shading drifts)
    az += autocorr((ft - mean).mul(mt));
    if (nt < static_cast<double>(r.area())) {
      am += autocorr(mt);
    } else {
      if (full_pairs.empty()) full_pairs = autocorr(mt);
      am += full_pairs;
    }
    n += nt;
  }
  if (!(n > 16)) return kNaN;
  // Normalised per lag by the number of pixel pairs, radially averaged up to a quarter
  // of the tile's shorter side.
  const int rmax = std::min(th, tw) / 4;
  std::vector<double> sum(static_cast<std::size_t>(rmax) + 2, 0.0), cnt(sum.size(), 0.0);
  for (int dy = -rmax; dy <= rmax; ++dy)
    for (int dx = -rmax; dx <= rmax; ++dx) {
      const auto bin = static_cast<std::size_t>(std::lround(std::hypot(dx, dy)));
      if (bin > static_cast<std::size_t>(rmax)) continue;
      const int yy = (dy + h) % h, xx = (dx + w) % w;
      const double pairs = am.at<float>(yy, xx);
      if (pairs < 0.25 * n) continue;  // too few pairs at this lag
      sum[bin] += az.at<float>(yy, xx) / pairs;
      cnt[bin] += 1;
    }
  const double c0 = sum[0];
  if (!(c0 > 0)) return kNaN;
  double prev = 1.0;
  for (std::size_t r = 1; r <= static_cast<std::size_t>(rmax); ++r) {
    if (cnt[r] == 0) return kNaN;
    const double c = sum[r] / cnt[r] / c0;
    if (c <= 0.5) return static_cast<double>(r - 1) + (prev - 0.5) / (prev - c);
    prev = c;
  }
  return kNaN;
}

std::vector<int> windows_for_texture(const std::vector<int>& windows, double half_width_px,
                                     cv::Size image) {
  if (windows.empty() || !std::isfinite(half_width_px)) return windows;
  const int largest_allowed = std::min(256, std::min(image.width, image.height));
  int factor = 1;
  while (windows.back() * factor < kFinalWindowPerHalfWidth * half_width_px &&
         windows.front() * factor * 2 <= largest_allowed)
    factor *= 2;
  std::vector<int> out(windows);
  for (int& w : out) w *= factor;
  const double bead_px = half_width_px * kBeadDiameterPerHalfWidth;
  if (bead_px >= kSmallBeadMinPx)
    while (out.back() > kMaxFinalWindowBeads * bead_px && out.back() / 2 >= kMinFinalWindowPx &&
           out.back() / 2 >= kFinalWindowPerHalfWidth * half_width_px)
      out.push_back(out.back() / 2);
  return out;
}

PredictorFit predictor_fit_for_texture(double half_width_px) {
  return half_width_px * kBeadDiameterPerHalfWidth >= kSmallBeadMinPx ? PredictorFit::kQuadratic
                                                                       : PredictorFit::kGaussian;
}

}  // namespace shearzone::piv
