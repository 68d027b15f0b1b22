// src/pipeline/angle_log.hpp (private): the vane angle log, a CSV with columns time_s and
// angle_rad, read by `piv` (the vane mask) and `profile` (the drive phase) alike.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/io/csv.hpp"

namespace shearzone::pipeline {

struct AngleLog {
  std::vector<double> time_s, angle_rad;
};

/// Reads the log; InputError for fewer than `min_rows` rows or times that do not strictly
/// increase (file:line, the value, what was expected).
inline AngleLog read_angle_log(const std::string& path, std::size_t min_rows) {
  const io::CsvTable t = io::read_csv(path);
  AngleLog log{t.numeric_column("time_s"), t.numeric_column("angle_rad")};
  if (log.time_s.size() < min_rows)
    throw InputError(fmt::format("{}: the angle log has {} rows; expected at least {}", path, log.time_s.size(),
                                 min_rows));
  for (std::size_t r = 1; r < log.time_s.size(); ++r)
    if (!(log.time_s[r] > log.time_s[r - 1]))
      throw InputError(fmt::format("{}:{}: column \"time_s\": {} does not increase (previous row has {}); expected "
                                   "strictly increasing times",
                                   path, t.row_lines[r], io::format_number(log.time_s[r]),
                                   io::format_number(log.time_s[r - 1])));
  return log;
}

}  // namespace shearzone::pipeline
