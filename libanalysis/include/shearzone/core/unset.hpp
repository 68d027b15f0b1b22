// shearzone/core/unset.hpp: the one spelling of "no value" for a double.
//
// An option the user did not give (the job then derives it or refuses) and a result
// that could not be computed (a bin without data, a fit without a standard error) are
// both the quiet NaN `kUnset`. Writers put it out as an empty CSV cell or a NaN HDF5
// attribute, never as 0. Integers use their own documented sentinel (0: none, -1: to
// the end) next to the field.
#pragma once

#include <cmath>
#include <limits>

namespace shearzone::core {

inline constexpr double kUnset = std::numeric_limits<double>::quiet_NaN();

/// True when `v` carries a value (is not kUnset / NaN).
[[nodiscard]] inline bool is_set(double v) { return !std::isnan(v); }

}  // namespace shearzone::core
