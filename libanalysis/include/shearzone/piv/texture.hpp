// shearzone/piv/texture.hpp: the image's texture size, and interrogation windows sized to it.
//
// A bead's correlation peak is about a bead wide. A final window much smaller than a bead
// sees part of one smooth bead (no texture across one direction: the aperture problem),
// so its vectors fail or fall back to the peak, which reads low (docs/piv.md, "Bead size
// and bias"). The texture size is measured from the image itself: the radius at which
// the image's normalised autocorrelation (masked pixels left out) falls to 0.5. On
// shaded beads (`synth beads`, 8-64 px) that half-width is 0.225 bead diameters
// (8 px beads: 1.7 px, 64 px: 14.6 px); on seeded particles of 3 px it is about 1 px.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "shearzone/piv/options.hpp"

namespace shearzone::piv {

/// Ratio of a shaded bead's diameter to its image's autocorrelation half-width
/// (measured on `synth beads` of 8-64 px: 0.21-0.23).
constexpr double kBeadDiameterPerHalfWidth = 1.0 / 0.225;
/// A final window at least this many autocorrelation half-widths wide (2/3 of a bead):
/// 24 px beads keep 16 px windows, 36 and 48 px beads get 32 px, 64 px beads 64 px.
constexpr double kFinalWindowPerHalfWidth = 2.5;

/// Radius, px, at which the normalised autocorrelation of `image` (any depth, one
/// channel), radially averaged, first falls to 0.5; pixels where `mask` (8-bit,
/// optional) is non-zero take no part. Linear, not circular, correlation (zero padding)
/// over up to 6 tiles of 256 px, those with the most unmasked pixels (at least a quarter;
/// the whole image if smaller than a tile).
/// Returns NaN where it cannot be measured (no variance, or it never falls to 0.5
/// within a quarter of a tile: 64 px, beads of about 280 px).
double texture_half_width_px(const cv::Mat& image, const cv::Mat& mask = {});

/// The most bead diameters a final window may span (windows_for_texture): a window
/// spanning more beads than this averages their independent motions (granular
/// rattling), and mean |v| reads low: at 8 px per bead, 16 px windows read the closed
/// loop's r_c 0.4-1 bead diameters low, 8 px windows within 0.22 (docs/sim.md). 1.6:
/// rendered cups of 8 and 10 px beads (texture 7.1 and 8.7 px) gain from 8 px windows;
/// the demo study's `synth beads` clips of 10 px beads (texture 10.3-10.5 px, beads that
/// follow a smooth field and do not rattle) lose (r_c 0.24 mm RMS from the truth against
/// 0.08 mm with 16 px windows).
constexpr double kMaxFinalWindowBeads = 1.6;
/// The smallest texture (as a shaded bead's diameter, px) taken for beads rather than
/// seeded particles: real particle pairs measure 2.9-5.3 px (OpenPIV, PIVlab jet and sand,
/// Oseen, Karman, the synthetic vane), rendered and `synth` beads of 8 px 7.1-8.0 px.
constexpr double kSmallBeadMinPx = 6.5;
/// The smallest final window a bead-sized rule adds, px.
constexpr int kMinFinalWindowPx = 8;

/// `windows` (coarse to fine) scaled by the smallest power of two that makes the final
/// window at least kFinalWindowPerHalfWidth x `half_width_px`, as far as the largest window
/// stays <= 256 px and <= the image's shorter side. Beads of kSmallBeadMinPx or more whose
/// final window spans more than kMaxFinalWindowBeads of them get passes of half the final
/// window added (the first windows, and so the displacement range, kept) while the new
/// final window stays >= kMinFinalWindowPx and >= kFinalWindowPerHalfWidth half-widths:
/// 64, 32, 16 becomes 64, 32, 16, 8 for textures of 6.5-10 px. A NaN half-width leaves
/// them as they are.
std::vector<int> windows_for_texture(const std::vector<int>& windows, double half_width_px,
                                     cv::Size image);

/// The predictor's smoothing fit for a texture: kQuadratic for beads (a shaded bead's
/// diameter of kSmallBeadMinPx or more), whose shear zones decay over a few grid steps
/// and which the Gaussian reads high (with it the closed loop's r_c read up to 0.38 bead
/// diameters low at 8-15 px per bead with MPEG-4, with the fit up to 0.24: docs/sim.md,
/// "Bead size, codec and the closed loop"); kGaussian for seeded particles, whose smooth flows
/// gain from its stronger averaging (the quadratic scatters 15-36 % more on the real
/// particle pairs), and where the texture could not be measured (NaN).
PredictorFit predictor_fit_for_texture(double half_width_px);

}  // namespace shearzone::piv
