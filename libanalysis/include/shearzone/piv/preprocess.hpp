// shearzone/piv/preprocess.hpp: image preprocessing before PIV.
//
// Applied to each frame in this order (each step optional):
//   1. background subtraction: frame - background, clipped at 0, where the background
//      is the per-pixel temporal median over (a sample of) the clip: removes the static
//      cup, reflections and dirt that would otherwise pull vectors to zero;
//   2. intensity capping (Shavit et al. 2007): values above median + k std of the
//      frame are set to that level, so a few bright glints do not dominate windows;
//   3. CLAHE (contrast-limited adaptive histogram equalisation, OpenCV), tiles of
//      clahe_tile_px, clip limit clahe_clip: evens out uneven lighting;
//   4. high-pass: frame - GaussianBlur(frame, sigma), clipped at 0: removes slow
//      intensity variations larger than about 3 sigma.
// The result is CV_32F in [0, 1] (fraction of full scale).
#pragma once

#include <string>

#include <opencv2/core.hpp>

#include "shearzone/core/metadata.hpp"

namespace shearzone::piv {

struct PreprocessOptions {
  bool background = false;        ///< subtract the temporal median (the pipeline computes it)
  int background_frames = 50;     ///< frames sampled, evenly spaced, for the median (>= 3)
  double intensity_cap = 0.0;     ///< k in median + k std (0: off; PIVlab uses about 2)
  bool clahe = false;
  int clahe_tile_px = 64;         ///< CLAHE tile size, px (>= 8)
  double clahe_clip = 2.0;        ///< CLAHE clip limit (> 0)
  double highpass_sigma_px = 0.0; ///< Gaussian sigma of the removed low-pass, px (0: off)

  bool any() const { return background || intensity_cap > 0 || clahe || highpass_sigma_px > 0; }
  void validate() const;
  core::Metadata to_metadata() const;
};

/// Preprocesses one grey frame (8-bit, 16-bit or float in [0, 1]). `background`
/// (CV_32F in [0, 1], same size) is used when options.background is set.
cv::Mat preprocess(const cv::Mat& frame, const PreprocessOptions& options,
                   const cv::Mat& background = {});

/// Per-pixel median of grey frames (all the same size), as CV_32F in [0, 1].
cv::Mat temporal_median(const std::vector<cv::Mat>& frames);

}  // namespace shearzone::piv
