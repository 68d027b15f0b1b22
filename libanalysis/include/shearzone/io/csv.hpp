// shearzone/io/csv.hpp: reading and writing the toolkit's CSV files.
//
// Format written (and preferred on input):
//     # tool: shearzone
//     # version: 0.1.0
//     # command_line: shearzone synth particles ...
//     # convention_image_axes: ...
//     x_px,y_px,u_px,v_px
//     8,8,2.25,-1.5
// A block of `# key: value` comment lines, one header row of column names (each
// with its unit), then data rows. RFC 4180 quoting: a field containing the
// separator, a quote or a line break is quoted, and quotes inside are doubled.
// Numbers are written in the shortest form that reads back to the same double.
//
// Accepted on input, in addition: a UTF-8 byte-order mark, CRLF line ends, blank
// lines, and the separators ',', ';' and TAB (detected from the header row). With
// ';' or TAB, a decimal comma in a number ("1,5") is read as a decimal point, as
// spreadsheets in many locales export it. pandas reads our files with
// `pd.read_csv(path, comment='#')`.
//
// Errors are InputError with `file:line:` and, for cells, the column name and the
// bad value: `torque.csv:1842: column "torque_N_m": "nan" is not a finite number`.
#pragma once

#include <cstddef>
#include <filesystem>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "shearzone/core/metadata.hpp"

namespace shearzone::io {

struct CsvTable {
  std::string source;                      ///< file name (or label) used in messages
  core::Metadata metadata;                 ///< leading `# key: value` lines
  std::vector<std::string> columns;        ///< header row
  std::size_t header_line = 0;             ///< 1-based line of the header row
  std::vector<std::vector<std::string>> rows;  ///< data cells, unquoted
  std::vector<std::size_t> row_lines;      ///< 1-based source line of each row
  char separator = ',';
  bool decimal_comma = false;              ///< true when ',' in numbers means '.'

  std::size_t num_rows() const { return rows.size(); }
  bool has_column(std::string_view name) const;
  /// Index of a column; throws InputError naming the file, the column and the
  /// columns that are there.
  std::size_t column_index(std::string_view name) const;
  /// The cell as a number; throws InputError with line, column and value.
  double number(std::size_t row, std::size_t col, bool require_finite = true) const;
  /// True when the cell holds nothing but blanks (a value left out on purpose).
  bool cell_empty(std::size_t row, std::size_t col) const;
  /// A whole column as numbers (see number()).
  std::vector<double> numeric_column(std::string_view name, bool require_finite = true) const;
  /// A whole column as text.
  std::vector<std::string> text_column(std::string_view name) const;
};

/// Parses CSV text. `source` names it in error messages.
CsvTable parse_csv(std::string_view text, const std::string& source);

/// Reads a CSV file; a missing or unreadable file is an InputError naming the path.
CsvTable read_csv(const std::filesystem::path& path);

/// At most `max_chars` of an input's text for a message, with the count of the rest:
/// an error line never echoes a whole (possibly megabytes long) header or cell.
std::string excerpt(std::string_view text, std::size_t max_chars = 120);

/// `text` without its leading and trailing blanks: spaces and TABs only, as CSV cells
/// and unit names are trimmed (the log readers' trim also drops CR, LF and no-break
/// spaces).
std::string_view trim_blanks(std::string_view text);

/// Reads a number the way CsvTable::number does (trimmed; optional decimal comma).
/// Returns false if `text` is not entirely a number.
bool parse_number(std::string_view text, bool decimal_comma, double& value);

/// Shortest text that reads back to exactly `value` ("0.1", "2.25", "1e-05"; "nan",
/// "inf", "-inf" for the non-finite): the one way the toolkit writes a double into a
/// CSV cell, a metadata line or a message (CsvWriter::format_number is the same).
std::string format_number(double value);

/// format_number(value) for a finite value; an empty cell (the value left out) for
/// NaN and for +-inf.
std::string format_number_or_empty(double value);

/// format_number(value), but an empty cell for NaN (a value that is not defined);
/// +-inf are written ("inf", "-inf"), unlike format_number_or_empty.
std::string format_number_nan_empty(double value);

/// Writes a CSV file row by row. The header block and the column row are written
/// by the constructor.
class CsvWriter {
 public:
  CsvWriter(std::ostream& out, const core::Metadata& metadata,
            const std::vector<std::string>& columns);
  void row(const std::vector<std::string>& cells);
  void row(const std::vector<double>& values);
  std::size_t num_columns() const { return num_columns_; }

  /// Shortest text that reads back to exactly `value`: io::format_number.
  static std::string format_number(double value);
  /// Shortest text that reads back to exactly the float `value` ("2.2979" not
  /// "2.297945022583008").
  static std::string format_float(float value);
  /// RFC 4180 quoting of one field (only when needed).
  static std::string quote(std::string_view field, char separator = ',');

 private:
  std::ostream& out_;
  std::size_t num_columns_;
};

}  // namespace shearzone::io
