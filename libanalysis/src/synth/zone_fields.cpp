#include "shearzone/synth/zone_fields.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <limits>
#include <random>

#include <fmt/format.h>

#include "shearzone/core/conventions.hpp"
#include "shearzone/core/error.hpp"

namespace shearzone::synth {

const char* zone_waveform_name(ZoneWaveform w) {
  switch (w) {
    case ZoneWaveform::kSine: return "sine";
    case ZoneWaveform::kClipped: return "clipped";
    case ZoneWaveform::kStickSlip: return "stick_slip";
  }
  return "?";
}

void ZoneFieldOptions::validate() const {
  auto positive = [](const char* what, double v) {
    if (!(std::isfinite(v) && v > 0)) throw ConfigError(fmt::format("zone fields: {} = {}: must be positive", what, v));
  };
  positive("m_per_px", m_per_px);
  positive("fps", fps);
  positive("spacing_px", spacing_px);
  positive("lambda_m", lambda_m);
  positive("f_Hz", f_Hz);
  if (!(width_px > 0 && height_px > 0 && width_px <= 16384 && height_px <= 16384))
    throw ConfigError(fmt::format("zone fields: frame {}x{} px: expected 1..16384", width_px, height_px));
  if (!(vane_radius_m >= 0 && cup_radius_m > vane_radius_m))
    throw ConfigError("zone fields: expected 0 <= vane radius < cup radius");
  if (!(std::isfinite(v0_m_per_s) && std::isfinite(t0_s) && std::isfinite(centre_x_px) && std::isfinite(centre_y_px)))
    throw ConfigError("zone fields: V0, t0 and the centre must be finite");
  if (!(level > 0 && level < 1)) throw ConfigError(fmt::format("zone fields: level {}: expected 0 < L < 1", level));
  if (!(noise_px >= 0 && noise_px < 100)) throw ConfigError(fmt::format("zone fields: noise {} px: expected 0..100", noise_px));
}

double zone_waveform(const ZoneFieldOptions& o, double theta) {
  const double c = std::cos(theta);
  switch (o.waveform) {
    case ZoneWaveform::kSine: return c;
    case ZoneWaveform::kClipped: return std::clamp(c, -o.level, o.level) / o.level;
    case ZoneWaveform::kStickSlip:
      return std::abs(c) > o.level ? (c - std::copysign(o.level, c)) / (1.0 - o.level) : 0.0;
  }
  return c;
}

double zone_waveform_mean_abs(const ZoneFieldOptions& o) {
  if (o.waveform == ZoneWaveform::kSine) return 2.0 / std::numbers::pi;
  // Closed forms over a quarter cycle (c = cos theta, theta in [0, pi/2]), a = acos L:
  // clipped: (theta a: 1) + (a..pi/2: cos / L) -> (a + (1 - sin a) / L) / (pi/2);
  // stick-slip: integral over [0, a] of (cos - L) / (1 - L) -> (sin a - L a) / (1 - L) / (pi/2).
  const double L = o.level, a = std::acos(L);
  if (o.waveform == ZoneWaveform::kClipped) return (a + (1.0 - std::sin(a)) / L) / (0.5 * std::numbers::pi);
  return (std::sin(a) - L * a) / (1.0 - L) / (0.5 * std::numbers::pi);
}

double zone_true_rc(const ZoneFieldOptions& o, double v_c) {
  const double m0 = o.v0_m_per_s * zone_waveform_mean_abs(o);
  if (!(m0 > v_c)) return std::numeric_limits<double>::quiet_NaN();
  const double r = o.vane_radius_m + o.lambda_m * std::log(m0 / v_c);
  return r <= o.cup_radius_m ? r : std::numeric_limits<double>::quiet_NaN();
}

core::VectorField zone_pair(const ZoneFieldOptions& o, std::size_t k) {
  o.validate();
  core::VectorField f;
  for (double x = 0.5 * o.spacing_px - 0.5; x < o.width_px; x += o.spacing_px) f.x_px.push_back(x);
  for (double y = 0.5 * o.spacing_px - 0.5; y < o.height_px; y += o.spacing_px) f.y_px.push_back(y);
  f.resize_to_grid();
  const double dt = 1.0 / o.fps, ta = static_cast<double>(k) * dt;
  // The waveform's mean over the pair's interval (exact for the sine; Simpson on 32
  // panels otherwise, with the kinks of the others well inside the quadrature error).
  const double w = 2.0 * std::numbers::pi * o.f_Hz;
  const double tha = w * (ta - o.t0_s), thb = w * (ta + dt - o.t0_s);
  double wbar = 0;
  if (o.waveform == ZoneWaveform::kSine) {
    wbar = (std::sin(thb) - std::sin(tha)) / (thb - tha);
  } else {
    constexpr int n = 32;
    for (int i = 0; i <= n; ++i) {
      const double wt = (i == 0 || i == n) ? 1.0 : (i % 2 ? 4.0 : 2.0);
      wbar += wt * zone_waveform(o, tha + (thb - tha) * i / n);
    }
    wbar /= 3.0 * n;
  }
  std::mt19937_64 rng(o.seed * 0x9E3779B97F4A7C15ULL + k);
  std::normal_distribution<double> z(0.0, 1.0);
  const double scale = dt / o.m_per_px;  // m/s -> px per pair
  for (std::size_t i = 0; i < f.ny(); ++i)
    for (std::size_t j = 0; j < f.nx(); ++j) {
      const std::size_t n = f.index(i, j);
      const double r = std::hypot(f.x_px[j] - o.centre_x_px, f.y_px[i] - o.centre_y_px) * o.m_per_px;
      if (r < o.vane_radius_m || r > o.cup_radius_m) {
        f.flag[n] = core::VectorFlag::kMasked;
        continue;
      }
      const double vt = o.v0_m_per_s * std::exp(-(r - o.vane_radius_m) / o.lambda_m) * wbar;
      const auto [u, v] = core::cartesian_from_azimuthal(f.x_px[j], f.y_px[i], vt, o.centre_x_px, o.centre_y_px);
      f.u_px[n] = static_cast<float>(u * scale + o.noise_px * z(rng));
      f.v_px[n] = static_cast<float>(v * scale + o.noise_px * z(rng));
      f.peak[n] = 1.0f;
      f.peak_ratio[n] = 10.0f;
    }
  return f;
}

}  // namespace shearzone::synth
