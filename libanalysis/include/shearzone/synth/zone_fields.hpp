// shearzone/synth/zone_fields.hpp: PIV vector fields of an oscillating shear zone, with
// their exact truth (no images: the fields a perfect PIV with Gaussian noise would give).
//
// The vane (radius Rv) oscillates as phi(t) = phi0 sin(theta), theta = 2 pi f (t - t0);
// the beads at radius r move azimuthally with
//     v_theta(r, t) = V0 exp(-(r - Rv) / lambda) w(theta),
// w(theta) = cos(theta) (in phase with the vane's angular velocity), or a non-sinusoidal
// waveform of the same sign: `clipped` min(max(cos, -L), L) / L, or `stick_slip`
// (cos - L sign(cos)) / (1 - L) where |cos| > L and 0 where the beads stick. A pair of
// frames (t_a, t_a + 1/fps) gets the displacement integral of v over its interval, in px
// (counter-clockwise v_theta > 0 as the camera sees it; image y downwards), plus
// independent Gaussian noise of `noise_px` per component and vector. Nodes outside the
// annulus Rv <= r <= R are masked. Pair k is drawn from its own seeded generator, so any
// pair can be made alone and the result does not depend on the order.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "shearzone/core/vector_field.hpp"

namespace shearzone::synth {

enum class ZoneWaveform { kSine, kClipped, kStickSlip };
const char* zone_waveform_name(ZoneWaveform w);

struct ZoneFieldOptions {
  double m_per_px = 1e-4;      ///< scale
  double fps = 25.0;           ///< frame rate; a pair spans 1 / fps
  double spacing_px = 8.0;     ///< grid step (nodes at spacing/2 + i spacing)
  int width_px = 1920, height_px = 1080;  ///< the frame the grid covers
  double centre_x_px = 959.5, centre_y_px = 539.5;
  double vane_radius_m = 0.0125, cup_radius_m = 0.034;
  double lambda_m = 0.002;     ///< decay length of the zone
  double v0_m_per_s = 4.4e-3;  ///< amplitude at the vane
  double f_Hz = 0.1;           ///< drive frequency
  double t0_s = 0.0;           ///< upward zero crossing of phi(t)
  ZoneWaveform waveform = ZoneWaveform::kSine;
  double level = 0.5;          ///< L of the clipped and stick-slip waveforms, 0 < L < 1
  double noise_px = 0.02;      ///< Gaussian noise per component, px
  std::uint64_t seed = 1;
  /// ConfigError naming the bad option.
  void validate() const;
};

/// w(theta) of the options' waveform.
double zone_waveform(const ZoneFieldOptions& o, double theta);
/// Cycle mean of |w| (2/pi for the sine), by quadrature.
double zone_waveform_mean_abs(const ZoneFieldOptions& o);
/// The true r_c: the radius where mean |v_theta| over a cycle, V0 e^{-(r-Rv)/lambda}
/// mean|w|, equals v_c (NaN when it never does inside the annulus).
double zone_true_rc(const ZoneFieldOptions& o, double v_c_m_per_s);

/// Pair k: frames (k, k + 1), t_a = k / fps.
core::VectorField zone_pair(const ZoneFieldOptions& o, std::size_t k);

}  // namespace shearzone::synth
