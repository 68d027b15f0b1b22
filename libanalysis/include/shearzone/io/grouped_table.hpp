// shearzone/io/grouped_table.hpp: a CSV table's (x, y[, sigma]) rows split into groups
// by a column, as the fits and the collapse read them (`fit erf|power`, `collapse erf`).
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace shearzone::io {

/// The rows of a table split into groups. A status column (`status` of the fit tables,
/// `rc_status` of widths.csv) keeps the rows that are `ok` and counts the others. Numeric
/// group values within `group_rtol` (relative) of the group's first are one group, labelled
/// by their mean; text groups keep their order of first appearance. Without a group
/// column every row is in one group, "all". InputError names file:line (a non-positive
/// sigma, an empty group value, no row ok, no data rows).
struct GroupedData {
  std::vector<std::string> labels;       ///< group label (numeric groups: the mean value)
  std::vector<double> group_values;      ///< numeric value of each group (NaN if text)
  std::vector<std::vector<double>> x, y, sigma;
  std::string x_unit, y_unit;            ///< from the column names' suffixes ("" unknown)
  std::size_t skipped_rows = 0;          ///< rows skipped for status != ok
};
GroupedData read_grouped(const std::filesystem::path& input, const std::string& x_column,
                         const std::string& y_column, const std::string& sigma_column,
                         const std::string& group_column, double group_rtol);

/// The unit in a column name: the text after the first '_' ("rc_m" -> "m",
/// "torque_N_m" -> "N_m"); "" when there is none.
std::string unit_of_column(const std::string& column);

}  // namespace shearzone::io
