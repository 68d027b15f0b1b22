// shearzone/synth/camera.hpp: the down-looking camera's checks.
#include "shearzone/synth/camera.hpp"

#include <cmath>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"

namespace shearzone::synth {

void DownCamera::validate() const {
  if (!(width_px >= 16 && width_px <= 16384 && height_px >= 16 && height_px <= 16384))
    throw ConfigError(fmt::format("camera resolution {}x{} px: expected 16..16384 px each way", width_px, height_px));
  if (!(m_per_px > 0 && std::isfinite(m_per_px)))
    throw ConfigError(fmt::format("camera scale {} m per px: expected a finite scale > 0", m_per_px));
  if (!orthographic && !(height_m > 0 && std::isfinite(height_m)))
    throw ConfigError(fmt::format("camera height {} m: expected a finite height > 0 above the surface", height_m));
  if (!(std::isfinite(centre_x_px) && std::isfinite(centre_y_px) && std::isfinite(axis_x_m) &&
        std::isfinite(axis_y_m) && std::isfinite(z_ref_m)))
    throw ConfigError("camera: the axis and its image must be finite");
}

}  // namespace shearzone::synth
