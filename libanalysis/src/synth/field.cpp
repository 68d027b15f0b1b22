#include "shearzone/synth/field.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>

#include <fmt/format.h>

#include "shearzone/core/enum_names.hpp"
#include "shearzone/core/error.hpp"
#include "shearzone/io/csv.hpp"

namespace shearzone::synth {

namespace {
using io::format_number;
}  // namespace

const char* field_kind_name(FieldKind kind) {
  switch (kind) {
    case FieldKind::kUniform: return "uniform";
    case FieldKind::kRotation: return "rotation";
    case FieldKind::kShearZone: return "shear-zone";
  }
  return "?";
}

std::vector<std::string> field_kind_names() { return {"uniform", "rotation", "shear-zone"}; }

FieldKind field_kind_from_name(const std::string& name) {
  return core::enum_from_name(name, {FieldKind::kUniform, FieldKind::kRotation, FieldKind::kShearZone},
                              field_kind_name, "field");
}

void FieldOptions::validate() const {
  auto finite = [](const char* what, double v) {
    if (!std::isfinite(v))
      throw ConfigError(fmt::format("FieldOptions::{} = {}: must be a finite number", what, v));
  };
  finite("u_px", u_px);
  finite("v_px", v_px);
  finite("omega_rad", omega_rad);
  finite("U0_px", U0_px);
  // A displacement beyond a few images per frame is no PIV test; bounding it keeps
  // the tracer domain (which grows with it) small.
  constexpr double kMaxShiftPx = 4096;
  for (auto [what, v] : {std::pair{"u_px (--u)", u_px}, std::pair{"v_px (--v)", v_px}, std::pair{"U0_px (--U0)", U0_px}})
    if (std::abs(v) > kMaxShiftPx)
      throw ConfigError(fmt::format("FieldOptions::{} = {}: expected |value| <= {} px per frame", what, v,
                                    kMaxShiftPx));
  if (std::abs(omega_rad) > std::numbers::pi)
    throw ConfigError(fmt::format("FieldOptions::omega_rad (--omega) = {}: expected |omega| <= pi rad per "
                                  "frame (a larger turn aliases)",
                                  omega_rad));
  if (!(r0_px > 0) || !std::isfinite(r0_px))
    throw ConfigError(fmt::format("FieldOptions::r0_px = {}: must be > 0", r0_px));
  if (!(w_px > 0) || !std::isfinite(w_px))
    throw ConfigError(fmt::format("FieldOptions::w_px = {}: must be > 0", w_px));
  if (std::isinf(centre_x_px) || std::isinf(centre_y_px))
    throw ConfigError("FieldOptions::centre: must be finite (or unset for the image centre)");
}

void FieldOptions::resolve_centre(int width_px, int height_px) {
  if (std::isnan(centre_x_px)) centre_x_px = 0.5 * (width_px - 1);
  if (std::isnan(centre_y_px)) centre_y_px = 0.5 * (height_px - 1);
}

core::Metadata FieldOptions::to_metadata() const {
  core::Metadata m{{"field", field_kind_name(kind)}};
  switch (kind) {
    case FieldKind::kUniform:
      m.emplace_back("field_u_px_per_frame", format_number(u_px));
      m.emplace_back("field_v_px_per_frame", format_number(v_px));
      break;
    case FieldKind::kRotation:
      m.emplace_back("field_centre_px", format_number(centre_x_px) + "," + format_number(centre_y_px));
      m.emplace_back("field_omega_rad_per_frame", format_number(omega_rad));
      break;
    case FieldKind::kShearZone:
      m.emplace_back("field_centre_px", format_number(centre_x_px) + "," + format_number(centre_y_px));
      m.emplace_back("field_r0_px", format_number(r0_px));
      m.emplace_back("field_w_px", format_number(w_px));
      m.emplace_back("field_U0_px_per_frame", format_number(U0_px));
      break;
  }
  return m;
}

DisplacementField::DisplacementField(const FieldOptions& options) : opt_(options) {
  opt_.validate();
  if (opt_.kind != FieldKind::kUniform && (std::isnan(opt_.centre_x_px) || std::isnan(opt_.centre_y_px)))
    throw ConfigError("DisplacementField: the centre is unset (call FieldOptions::resolve_centre)");
}

std::array<double, 2> DisplacementField::operator()(double x, double y) const {
  switch (opt_.kind) {
    case FieldKind::kUniform: return {opt_.u_px, opt_.v_px};
    case FieldKind::kRotation: {
      const double dx = x - opt_.centre_x_px, dy = y - opt_.centre_y_px;
      return {opt_.omega_rad * dy, -opt_.omega_rad * dx};
    }
    case FieldKind::kShearZone: {
      const double dx = x - opt_.centre_x_px, dy = y - opt_.centre_y_px;
      const double r = std::hypot(dx, dy);
      if (r <= opt_.r0_px) {
        const double omega = opt_.U0_px / opt_.r0_px;  // solid rotation inside the core
        return {omega * dy, -omega * dx};
      }
      const double s = opt_.U0_px * std::exp(-(r - opt_.r0_px) / opt_.w_px);
      return {s * dy / r, -s * dx / r};
    }
  }
  return {0.0, 0.0};
}

double DisplacementField::max_speed(int width_px, int height_px) const {
  switch (opt_.kind) {
    case FieldKind::kUniform: return std::hypot(opt_.u_px, opt_.v_px);
    case FieldKind::kRotation: {
      double rmax = 0;
      for (double x : {0.0, width_px - 1.0})
        for (double y : {0.0, height_px - 1.0})
          rmax = std::max(rmax, std::hypot(x - opt_.centre_x_px, y - opt_.centre_y_px));
      return std::abs(opt_.omega_rad) * rmax;
    }
    case FieldKind::kShearZone: return std::abs(opt_.U0_px);  // maximum at r = r0
  }
  return 0.0;
}

}  // namespace shearzone::synth
