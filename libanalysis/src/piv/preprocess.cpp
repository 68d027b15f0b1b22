#include "shearzone/piv/preprocess.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "shearzone/core/error.hpp"
#include "shearzone/core/stats.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/piv/piv.hpp"

namespace shearzone::piv {

void PreprocessOptions::validate() const {
  // The median holds every sampled frame in memory (1 byte per pixel each).
  if (background && (background_frames < 3 || background_frames > 500))
    throw ConfigError(fmt::format("PreprocessOptions::background_frames (--background-frames) = {}: "
                                  "expected 3 to 500",
                                  background_frames));
  if (!(intensity_cap >= 0))
    throw ConfigError("PreprocessOptions::intensity_cap: must be >= 0 (0: off)");
  if (clahe && (clahe_tile_px < 8 || clahe_tile_px > 4096 || !(clahe_clip > 0) || !std::isfinite(clahe_clip)))
    throw ConfigError(fmt::format("PreprocessOptions: CLAHE tile {} px and clip {}: need 8 <= tile <= "
                                  "4096 px and a finite clip > 0",
                                  clahe_tile_px, clahe_clip));
  // A Gaussian of sigma s needs a kernel of ~6 s px; beyond 256 px the high-pass
  // removes nothing a PIV window sees, and time and memory grow without bound.
  if (!(highpass_sigma_px >= 0 && highpass_sigma_px <= 256))
    throw ConfigError(fmt::format("PreprocessOptions::highpass_sigma_px (--highpass) = {}: expected 0..256 px "
                                  "(0: off)",
                                  highpass_sigma_px));
}

core::Metadata PreprocessOptions::to_metadata() const {
  return {
      {"preprocess_background",
       background ? fmt::format("temporal median of {} frames subtracted", background_frames)
                  : std::string("off")},
      {"preprocess_intensity_cap",
       intensity_cap > 0 ? "median + " + io::format_number(intensity_cap) + " std" : "off"},
      {"preprocess_clahe",
       clahe ? fmt::format("tile {} px, clip {}", clahe_tile_px, io::format_number(clahe_clip))
             : std::string("off")},
      {"preprocess_highpass_sigma_px", highpass_sigma_px > 0 ? io::format_number(highpass_sigma_px) : "off"}};
}

cv::Mat temporal_median(const std::vector<cv::Mat>& frames) {
  if (frames.empty()) throw InputError("background: no frames to take a median of");
  const cv::Size size = frames.front().size();
  std::vector<cv::Mat> f;
  for (const auto& m : frames) {
    if (m.size() != size) throw InputError("background: frames differ in size");
    f.push_back(to_unit_float(m));
  }
  cv::Mat out(size, CV_32F);
  const std::size_t n = f.size();
#pragma omp parallel
  {
    std::vector<float> v(n);
#pragma omp for schedule(static)
    for (int i = 0; i < size.height; ++i) {
      float* o = out.ptr<float>(i);
      for (int j = 0; j < size.width; ++j) {
        for (std::size_t k = 0; k < n; ++k) v[k] = f[k].ptr<float>(i)[j];
        o[j] = core::upper_median_inplace(v);
      }
    }
  }
  return out;
}

cv::Mat preprocess(const cv::Mat& frame, const PreprocessOptions& o, const cv::Mat& background) {
  cv::Mat img = to_unit_float(frame);
  if (o.background) {
    if (background.size() != img.size() || background.type() != CV_32F)
      throw InputError("background: the median image does not match the frame size");
    cv::subtract(img, background, img);
    cv::max(img, 0.0, img);
  }
  if (o.intensity_cap > 0) {
    cv::Scalar mean, sd;
    cv::meanStdDev(img, mean, sd);
    std::vector<float> v(img.begin<float>(), img.end<float>());
    const double cap = core::upper_median_inplace(v) + o.intensity_cap * sd[0];
    cv::min(img, cap, img);
  }
  if (o.clahe) {
    cv::Mat u16;
    img.convertTo(u16, CV_16U, 65535.0);
    auto clahe = cv::createCLAHE(o.clahe_clip, cv::Size(std::max(1, img.cols / o.clahe_tile_px),
                                                        std::max(1, img.rows / o.clahe_tile_px)));
    clahe->apply(u16, u16);
    u16.convertTo(img, CV_32F, 1.0 / 65535.0);
  }
  if (o.highpass_sigma_px > 0) {
    cv::Mat low;
    cv::GaussianBlur(img, low, cv::Size(0, 0), o.highpass_sigma_px, 0, cv::BORDER_REFLECT);
    cv::subtract(img, low, img);
    cv::max(img, 0.0, img);
  }
  return img;
}

}  // namespace shearzone::piv
