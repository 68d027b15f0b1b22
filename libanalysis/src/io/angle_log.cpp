#include "shearzone/io/angle_log.hpp"

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/io/csv.hpp"

namespace shearzone::io {

AngleLog read_angle_log(const std::string& path, std::size_t min_rows) {
  const CsvTable t = read_csv(path);
  AngleLog log{t.numeric_column("time_s"), t.numeric_column("angle_rad")};
  if (log.time_s.size() < min_rows)
    throw InputError(fmt::format("{}: the angle log has {} rows; expected at least {}", path, log.time_s.size(),
                                 min_rows));
  for (std::size_t r = 1; r < log.time_s.size(); ++r)
    if (!(log.time_s[r] > log.time_s[r - 1]))
      throw InputError(fmt::format("{}:{}: column \"time_s\": {} does not increase (previous row has {}); expected "
                                   "strictly increasing times",
                                   path, t.row_lines[r], format_number(log.time_s[r]),
                                   format_number(log.time_s[r - 1])));
  return log;
}

void write_angle_log(std::ostream& out, const core::Metadata& metadata, const AngleLog& log) {
  CsvWriter w(out, metadata, {"time_s", "angle_rad"});
  for (std::size_t r = 0; r < log.time_s.size(); ++r) w.row(std::vector<double>{log.time_s[r], log.angle_rad[r]});
}

}  // namespace shearzone::io
