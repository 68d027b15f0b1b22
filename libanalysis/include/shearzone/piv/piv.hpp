// shearzone/piv/piv.hpp: multipass PIV of one image pair.
//
// Per pass (coarse to fine, the final window optionally repeated):
//   1. Build the window grid: windows of W px every step px, the first at pixel 0;
//      the window covering columns [s, s+W-1] has its centre at x = s + (W-1)/2.
//   2. Predictor: the previous pass's validated, gap-filled and smoothed field,
//      interpolated bilinearly to the window centres and to every pixel.
//   3. Deform A and B symmetrically by half the predictor each (deform.hpp).
//   4. Correlate every unmasked window (FFT, normalised), find the peak (full plane
//      in the first pass, within restricted_search * W after) and fit it to
//      sub-pixel; displacement = predictor + residual.
//   0. (coarse_estimate) Templates of the first window's footprint matched at half
//      resolution within +-1 first window; where the largest valid coarse
//      displacement exceeds a quarter of the first window, the coarse field is the
//      first pass's predictor (the first pass then deforms, like the later ones).
//      A pair whose coarse templates are mostly unmatched is refused (all invalid).
//   5. Validate: no texture or a peak below min_peak -> invalid; normalised median
//      test, std filter and displacement limit -> replaced; fill both by
//      interpolation from valid neighbours.
// Masked windows (centre masked, or more than mask_fraction of the pixels masked in
// A or B) are not correlated and not used by validation; they come out with u = v = 0.
// Masked pixels inside an unmasked window are set to the window's mean, so the
// vane's edge does not correlate.
//
// Thread-safety: process() is const and uses OpenMP over windows internally; one
// engine may serve several threads. Results are identical for any thread count.
#pragma once

#include <cstddef>
#include <limits>
#include <memory>
#include <vector>

#include <opencv2/core.hpp>

#include "shearzone/core/vector_field.hpp"
#include "shearzone/piv/options.hpp"

namespace shearzone::piv {

class Correlator;

struct PassReport {
  int window_px = 0;
  int step_px = 0;
  std::size_t nx = 0, ny = 0;
  std::size_t valid = 0, replaced = 0, masked = 0, invalid = 0;
  double peak_threshold = 0;  ///< the peak-height threshold applied (0: none, first pass)
};

struct PivResult {
  core::VectorField field;          ///< the final pass
  std::vector<PassReport> passes;   ///< one per pass run (repeats included)
  /// Largest valid displacement of the coarse estimate, px of the full image (NaN:
  /// no estimate: off, a first window below 16 px, or images too small).
  double coarse_max_displacement_px = std::numeric_limits<double>::quiet_NaN();
  /// Whether the coarse field was the first pass's predictor.
  bool coarse_predictor = false;
  /// Fraction of the coarse estimate's textured templates matched within +-1 first
  /// window (NaN: no estimate, or fewer than 4 textured templates).
  double coarse_matched_fraction = std::numeric_limits<double>::quiet_NaN();
  /// The pair was refused (every unmasked vector invalid): the coarse estimate
  /// matched under a quarter of its templates (displacements beyond one first
  /// window, or unrelated frames).
  bool coarse_refused = false;
};

class PivEngine {
 public:
  /// Validates the options (ConfigError) and prepares the FFT plans.
  explicit PivEngine(PivOptions options);
  ~PivEngine();
  PivEngine(const PivEngine&) = delete;
  PivEngine& operator=(const PivEngine&) = delete;

  const PivOptions& options() const { return opt_; }

  /// Processes a pair. Images: single channel, CV_8U, CV_16U or CV_32F (8 and 16 bit
  /// are scaled to [0, 1]), same size, at least the first window in each direction.
  /// Masks: empty or CV_8U of the same size, non-zero = masked. Throws InputError on
  /// mismatched sizes or types.
  PivResult process(const cv::Mat& a, const cv::Mat& b, const cv::Mat& mask_a = {},
                    const cv::Mat& mask_b = {}) const;

  /// The final-pass grid for an image size (x_px, y_px), without processing.
  void final_grid(cv::Size size, std::vector<double>& x_px, std::vector<double>& y_px) const;

 private:
  PivOptions opt_;
  std::vector<std::unique_ptr<Correlator>> correlators_;  // one per distinct window size
  const Correlator& correlator(int window_px) const;
};

/// Converts a grey image to CV_32F in [0, 1] (8-bit / 255, 16-bit / 65535, float as is).
cv::Mat to_unit_float(const cv::Mat& image);

}  // namespace shearzone::piv
