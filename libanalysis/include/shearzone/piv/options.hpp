// shearzone/piv/options.hpp: the settings of the multipass PIV engine.
//
// Defaults follow the accuracy gates (docs/piv.md): three passes 64 -> 32 -> 16 px
// at 50 % overlap plus one repeat of the last, symmetric image deformation with a
// quintic B-spline (the cubic B-spline leaves 0.012 px of bias at half-pixel shifts
// of 3 px particles, bilinear and Keys 0.05-0.06 px), 3-point Gaussian sub-pixel fit,
// normalised median test with epsilon = 0.1 px and threshold 2 (Westerweel &
// Scarano 2005) between passes and after the last.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include "shearzone/core/metadata.hpp"

namespace shearzone::piv {

/// Image interpolation used to deform the frames between passes.
enum class Interpolation {
  kBilinear,  ///< PIVlab 2.55 "Standard": fast, biased for sub-pixel shifts
  kBicubic,   ///< Keys cubic convolution (a = -0.5), 4x4 pixels
  kBSpline,   ///< prefiltered cubic B-spline (interpolating), 4x4 coefficients
  kBSpline5,  ///< prefiltered quintic B-spline (interpolating), 6x6 coefficients
};
const char* interpolation_name(Interpolation i);
Interpolation interpolation_from_name(const std::string& name);

/// Sub-pixel peak estimator.
enum class Subpixel {
  kGauss3,   ///< 3-point Gaussian in x and in y (separable); the PIV standard
  kGauss2D,  ///< least-squares 2-D Gaussian on the 3x3 neighbourhood (Nobach & Honkanen 2005)
};
const char* subpixel_name(Subpixel s);
Subpixel subpixel_from_name(const std::string& name);

/// How the passes after the first measure what is left of the displacement once the
/// images are deformed by the predictor (docs/piv.md, "Bead size and bias").
enum class Residual {
  /// The correlation peak's sub-pixel position. Pulled towards zero on broad peaks: a
  /// window's edge loses pairs in proportion to the shift, so a bead texture's peak
  /// (about a bead wide) returns only part of the residual each pass.
  kPeak,
  /// One Gauss-Newton (Lucas-Kanade) step on the deformed windows, where the peak lies
  /// within a pixel of it and the window's texture has gradients across both directions;
  /// the peak elsewhere. No pairs leave the window, so each pass returns the whole residual.
  kGradient,
};
const char* residual_name(Residual r);
Residual residual_from_name(const std::string& name);

/// How the predictor is smoothed between passes, over `predictor_smoothing` S grid
/// steps (docs/piv.md, "Velocity profiles of beads").
enum class PredictorFit {
  /// A Gaussian of S steps. Averages the most noise, but a profile that curves within a
  /// few steps (a shear zone decaying over about a bead) reads high by about S^2/2 v''
  /// (steps squared), and the next pass removes only part of it.
  kGaussian,
  /// A least-squares quadratic through the points within +-max(2, round(2 S)) steps
  /// along each grid axis (Savitzky-Golay). Exact for quadratic fields, so a steep
  /// profile keeps its curvature; it averages less noise than the Gaussian.
  kQuadratic,
};
const char* predictor_fit_name(PredictorFit f);
PredictorFit predictor_fit_from_name(const std::string& name);
/// The weights of kQuadratic along one axis, for offsets -m..m: the centre value of the
/// least-squares quadratic through 2m + 1 equally spaced points,
/// 3 (3m^2 + 3m - 1 - 5 i^2) / ((2m + 1)(4m^2 + 4m - 3)) (m >= 2; 17/35, 12/35, -3/35
/// for m = 2). They sum to 1 and their second moment is 0.
std::vector<double> quadratic_fit_weights(int half_width);

struct PivOptions {
  /// Interrogation window side per pass, px, coarse to fine; each a power of two
  /// from 8 to 256 and not larger than the previous one.
  std::vector<int> windows_px = {64, 32, 16};
  /// Window overlap, fraction (0 <= overlap <= 0.875); the grid step is
  /// window * (1 - overlap), rounded to a whole pixel.
  double overlap = 0.5;
  /// Extra iterations of the final pass (re-deform with the refined field). One
  /// repeat costs a third of the time but halves the error in shear zones (0.095 ->
  /// 0.060 px RMS on the shear-zone field of docs/piv.md, "Accuracy") and removes the
  /// first pass's bias with two windows (0.011 px for 32 -> 16 without it). More
  /// repeats amplify noise.
  int final_pass_repeats = 1;
  /// Image interpolation for the deformation between passes.
  Interpolation interpolation = Interpolation::kBSpline5;
  /// Deform the images between passes. Off: later passes only offset the windows
  /// of A and B by the predictor rounded to whole pixels (no interpolation).
  bool deform = true;
  /// Sub-pixel estimator.
  Subpixel subpixel = Subpixel::kGauss3;
  /// Residual estimator of the passes after the first (with deformation).
  Residual residual = Residual::kGradient;
  /// Peak search radius in passes after the first, as a fraction of the window
  /// (the residual displacement is small once the images are deformed).
  double restricted_search = 0.25;
  /// Smoothing of the predictor between passes, in grid steps (0: off).
  double predictor_smoothing = 1.0;
  /// Its shape: a Gaussian of that many steps, or a local quadratic fit.
  PredictorFit predictor_fit = PredictorFit::kGaussian;
  /// Coarse estimate before the first pass: templates of the first window's footprint
  /// (W px) matched at half resolution within +-W px by normalised cross-correlation
  /// (no pairs leave a template, unlike the first pass's FFT correlation, which loses
  /// most beyond W/4 and where a static background's zero-displacement peak can win),
  /// validated by a peak of 0.5 and the median test. Where its largest valid
  /// displacement exceeds W/4 the coarse field is the first pass's predictor: the
  /// first pass is then deformed, with the restricted search and the peak tests of the
  /// later passes. Off, or below W/4, the passes are as without it.
  bool coarse_estimate = true;

  /// Normalised median test: neighbourhood radius in vectors (1: 3x3), noise level
  /// epsilon in px and threshold. threshold <= 0 switches the test off.
  int median_radius = 1;
  double median_epsilon_px = 0.1;
  double median_threshold = 2.0;
  /// Global std filter: |u - mean| > k std (k <= 0: off).
  double std_threshold = 0.0;
  /// Global limit on |d| in px (infinity: off).
  double max_displacement_px = std::numeric_limits<double>::infinity();
  /// After the first pass, a vector whose normalised correlation peak is below
  /// min(min_peak, min_peak_relative x the median peak of the pass) is invalid
  /// (min_peak_relative <= 0: min_peak alone). Correct matches of deformed synthetic
  /// windows reach 0.7-1; unrelated windows (a failed predictor, an aliased first
  /// pass) peak around 0.3-0.5; on the PIVlab sand frames (median peak 0.98), 0.6
  /// instead of 0.5 halves the inconsistency of the moving-sand vectors (1->3 against
  /// 1->2 + 2->3: 0.112 -> 0.055 px RMS). Seeded-particle recordings peak lower: the
  /// OpenPIV tutorial pair has a median of 0.64, and an absolute 0.6 invalidates 52 %
  /// of it; relative to the median (0.6 x 0.64 = 0.38) 97 % stay valid.
  double min_peak = 0.6;
  double min_peak_relative = 0.6;
  /// A vector whose peak ratio (first over second peak) is below this is invalid.
  double min_peak_ratio = 1.3;
  /// A window whose intensity standard deviation is below this fraction of the
  /// full scale has no texture: invalid.
  double min_window_std = 2e-3;
  /// A window is masked when its centre is masked or when more than this fraction
  /// of its pixels is masked (in frame A or B).
  double mask_fraction = 0.5;

  /// Throws ConfigError naming the option and the constraint.
  void validate() const;
  core::Metadata to_metadata() const;
  /// Grid step of pass p, px.
  int step_px(std::size_t pass) const;
  /// The quadratic fit's half-width, grid steps: max(2, round(2 predictor_smoothing)).
  int predictor_fit_half_width() const;
};

/// A named setting (`piv --preset`): the window sequence, deformation interpolation,
/// sub-pixel fit, repeats of the final pass and predictor smoothing; every other option
/// keeps its default. Measured speed and accuracy of each: docs/piv.md, "Presets".
struct PivPreset {
  const char* name;
  const char* summary;
  std::vector<int> windows_px;
  Interpolation interpolation;
  Subpixel subpixel;
  int final_pass_repeats;
  double predictor_smoothing;
  /// Sets the preset's five settings in `o`.
  void apply(PivOptions& o) const;
  /// Whether `o` has the preset's five settings.
  bool matches(const PivOptions& o) const;
};
/// accurate, default, fast, profile (in that order).
const std::vector<PivPreset>& piv_presets();
/// ConfigError naming the presets if `name` is none of them.
const PivPreset& piv_preset(const std::string& name);

}  // namespace shearzone::piv
