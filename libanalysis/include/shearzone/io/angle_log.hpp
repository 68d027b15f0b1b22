// shearzone/io/angle_log.hpp: the vane angle log, a CSV with columns time_s and
// angle_rad (a rheometer's or `shearzone sim render`'s vane_angle.csv), read by `piv`
// (the vane mask) and `profile` (the drive phase) alike.
#pragma once

#include <cstddef>
#include <ostream>
#include <string>
#include <vector>

#include "shearzone/core/metadata.hpp"

namespace shearzone::io {

struct AngleLog {
  std::vector<double> time_s, angle_rad;
};

/// Reads the log; InputError for fewer than `min_rows` rows or times that do not strictly
/// increase (file:line, the value, what was expected).
AngleLog read_angle_log(const std::string& path, std::size_t min_rows);

/// Writes the log (the header `metadata`, then a row per sample; every digit of each value).
void write_angle_log(std::ostream& out, const core::Metadata& metadata, const AngleLog& log);

}  // namespace shearzone::io
