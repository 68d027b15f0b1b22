// shearzone/synth/field.hpp: analytic displacement fields with exact ground truth.
//
// All fields give a displacement per frame, in px, at an image position (x, y) in
// the project's image convention (x right, y down; README "Conventions").
//   uniform     d = (u, v)
//   rotation    d = omega (y - yc, -(x - xc))          omega in rad per frame,
//                                                        > 0 counter-clockwise on screen
//   shear-zone  speed s(r) = U0 r / r0                for r <= r0 (solid rotation)
//                      s(r) = U0 exp(-(r - r0) / w)    for r >  r0
//               d = s(r) ((y - yc), -(x - xc)) / r    (counter-clockwise for U0 > 0)
// The shear-zone field mimics the surface flow around an oscillating vane: a rigid
// core out to the blade radius r0, then an exponentially decaying shear zone.
#pragma once

#include <array>
#include <limits>
#include <string>
#include <vector>

#include "shearzone/core/metadata.hpp"
#include "shearzone/core/unset.hpp"

namespace shearzone::synth {

enum class FieldKind { kUniform, kRotation, kShearZone };

/// "uniform", "rotation", "shear-zone".
const char* field_kind_name(FieldKind kind);
/// Inverse of field_kind_name; ConfigError lists the valid names.
FieldKind field_kind_from_name(const std::string& name);
/// The valid names, for help texts.
std::vector<std::string> field_kind_names();

struct FieldOptions {
  FieldKind kind = FieldKind::kUniform;
  /// uniform: displacement per frame, px.
  double u_px = 0.0;
  double v_px = 0.0;
  /// rotation and shear-zone: centre in px. NaN means the image centre
  /// ((width - 1) / 2, (height - 1) / 2), resolved by resolve_centre().
  double centre_x_px = core::kUnset;
  double centre_y_px = core::kUnset;
  /// rotation: angle per frame, rad; > 0 is counter-clockwise as the camera sees it.
  double omega_rad = 0.01;
  /// shear-zone: radius of the rigid core, px (> 0).
  double r0_px = 60.0;
  /// shear-zone: decay length of the speed outside the core, px (> 0).
  double w_px = 30.0;
  /// shear-zone: speed at r0, px per frame (> 0 counter-clockwise).
  double U0_px = 2.0;

  /// Throws ConfigError naming the field option and the violated constraint.
  void validate() const;
  /// Fills a NaN centre with the centre of a width x height image.
  void resolve_centre(int width_px, int height_px);
  /// The options as `field_*` metadata entries (resolved values).
  core::Metadata to_metadata() const;
};

/// Evaluates a field. Copyable, cheap, thread-safe (const).
class DisplacementField {
 public:
  explicit DisplacementField(const FieldOptions& options);
  /// Displacement per frame (u, v) in px at (x, y).
  std::array<double, 2> operator()(double x, double y) const;
  /// Largest |d| over the rectangle [0, w) x [0, h) (sampled on a fine grid plus the
  /// analytic maximum for the shear-zone core); used for margins.
  double max_speed(int width_px, int height_px) const;
  const FieldOptions& options() const { return opt_; }

 private:
  FieldOptions opt_;
};

}  // namespace shearzone::synth
