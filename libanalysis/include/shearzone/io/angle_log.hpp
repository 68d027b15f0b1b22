// shearzone/io/angle_log.hpp: the vane angle log, a CSV with columns time_s and
// angle_rad (a rheometer's or `shearzone sim render`'s vane_angle.csv), read by `piv`
// (the vane mask) and `profile` (the drive phase) alike.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace shearzone::io {

struct AngleLog {
  std::vector<double> time_s, angle_rad;
};

/// Reads the log; InputError for fewer than `min_rows` rows or times that do not strictly
/// increase (file:line, the value, what was expected).
AngleLog read_angle_log(const std::string& path, std::size_t min_rows);

}  // namespace shearzone::io
