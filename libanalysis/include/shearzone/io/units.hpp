// shearzone/io/units.hpp: units of rheometer logs, to SI.
//
// A unit is read after normalisation: surrounding brackets "[...]" or "(...)" are
// dropped; µ (U+00B5) and μ (U+03BC) read as u; spaces, the product signs · and ⋅,
// '.', '-', '*' and '_' between the parts are ignored (so "mN·m", "mN m", "mN.m",
// "mNm", "mN-m" and "mN_m" are one unit); ° reads as deg. Letters are case-sensitive
// (mN m is not MN m). Accepted, with the factor to SI:
//   time    s, sec (1), ms (1e-3), min (60)
//   angle   rad (1), mrad (1e-3), urad (1e-6), deg, ° (pi/180)
//   torque  N m (1), mN m (1e-3), uN m (1e-6), nN m (1e-9)
//   strain  1, - or nothing (dimensionless), % (1e-2)
//   stress  Pa (1), mPa (1e-3), kPa (1e3), MPa (1e6)
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace shearzone::io {

enum class UnitKind { kTime, kAngle, kTorque, kStrain, kStress };

/// "time", "angle", "torque", "strain", "stress".
const char* unit_kind_name(UnitKind kind);

/// The accepted spellings of a kind, for messages ("s, ms, min").
std::string accepted_units(UnitKind kind);

/// The normalised spelling used for matching ("[µN·m]" -> "uNm").
std::string normalize_unit(std::string_view unit);

/// Factor that converts a value in `unit` to SI; nullopt if the unit is not one of
/// the accepted ones of `kind`.
std::optional<double> find_unit_scale(std::string_view unit, UnitKind kind);

/// As find_unit_scale, but throws InputError
/// `<where>: unknown torque unit "lbf in"; accepted: N m, mN m, ...`.
double parse_unit(std::string_view unit, UnitKind kind, const std::string& where);

}  // namespace shearzone::io
