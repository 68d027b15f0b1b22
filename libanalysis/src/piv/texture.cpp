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
  const double n = cv::sum(m)[0];
  if (!(n > 16)) return kNaN;
  const double mean = cv::sum(f.mul(m))[0] / n;
  cv::Mat z = (f - mean).mul(m);
  // Linear correlation: pad to at least twice the size.
  const int h = cv::getOptimalDFTSize(2 * f.rows), w = cv::getOptimalDFTSize(2 * f.cols);
  auto autocorr = [&](const cv::Mat& x) {
    cv::Mat p = cv::Mat::zeros(h, w, CV_32F), spec, out;
    x.copyTo(p(cv::Rect(0, 0, x.cols, x.rows)));
    cv::dft(p, spec, cv::DFT_COMPLEX_OUTPUT);
    cv::mulSpectrums(spec, spec, spec, 0, true);
    cv::idft(spec, out, cv::DFT_REAL_OUTPUT | cv::DFT_SCALE);
    return out;
  };
  const cv::Mat az = autocorr(z), am = autocorr(m);
  // Normalised per lag by the number of pixel pairs, radially averaged up to a quarter
  // of the image's shorter side.
  const int rmax = std::min(f.rows, f.cols) / 4;
  std::vector<double> sum(static_cast<std::size_t>(rmax) + 2, 0.0), cnt(sum.size(), 0.0);
  for (int dy = -rmax; dy <= rmax; ++dy)
    for (int dx = -rmax; dx <= rmax; ++dx) {
      const double r = std::hypot(dx, dy);
      const auto bin = static_cast<std::size_t>(std::lround(r));
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
  return out;
}

}  // namespace shearzone::piv
