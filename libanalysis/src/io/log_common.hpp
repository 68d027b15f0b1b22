// Private to the rheometer log readers (src/io/log_*.cpp, oscillation_log.cpp): text
// helpers, sample columns with their SI scale, unit resolution and the localised column
// names shared by the vendor readers. Not part of the installed API.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "shearzone/io/oscillation_log.hpp"
#include "shearzone/io/units.hpp"

namespace shearzone::io::log_detail {

// ---- Text -------------------------------------------------------------------------

/// Trims ASCII white space and no-break spaces (U+00A0) that spreadsheet exports put
/// around cells.
std::string_view trim(std::string_view s);

struct TextLine {
  std::size_t number;     ///< 1-based
  std::string_view text;  ///< without the line break
};

/// Lines of a text (LF or CRLF), numbered from 1.
std::vector<TextLine> split_lines(std::string_view text);
/// Cells of a line split at `sep`, each trimmed.
std::vector<std::string_view> split_cells(std::string_view line, char sep);
/// Fields of a line separated by runs of spaces or tabs.
std::vector<std::string_view> split_whitespace(std::string_view line);
bool all_empty(const std::vector<std::string_view>& cells);
/// Index of the first non-empty cell (cells.size() when all are empty).
std::size_t first_nonempty(const std::vector<std::string_view>& cells);
/// For matching localised names: ASCII lower case, runs of spaces as one, typographic
/// apostrophes as '.
std::string fold(std::string_view s);
bool is_number(std::string_view cell);
/// A cell that is a unit in brackets: "[mN·m]".
bool is_bracketed(std::string_view cell);
/// Splits "Torque [mN·m]" or "Strain(-)" into name and unit (without brackets).
std::pair<std::string, std::string> split_bracketed_unit(std::string_view header);
/// "[Section]" on a line of its own (TRIOS).
bool is_section_header(std::string_view line);
/// Quoted, comma-separated names, bounded in length (a message quotes a bounded part of
/// the input).
std::string list_names(const std::vector<std::string>& names);

// ---- Samples ----------------------------------------------------------------------

/// A column of the source: where it is, what it is called, its factor to SI.
struct Column {
  std::size_t index = 0;
  std::string name;
  double scale = 1.0;
};

/// A finite number from a cell, or an InputError naming source, line and column.
double cell_value(std::string_view cell, bool decimal_comma, const std::string& source,
                  std::size_t line, const std::string& column);
/// The cell of `col` in a row, or an InputError if the row is too short.
std::string_view cell_of(const std::vector<std::string_view>& cells, const Column& col,
                         const std::string& source, std::size_t line);
/// Appends one sample read from `cells`.
void append_sample(LogSegment& seg, const std::vector<std::string_view>& cells,
                   const std::optional<Column>& time, const Column& drive,
                   const Column& response, bool decimal_comma, const std::string& source,
                   std::size_t line);
/// Time must increase strictly within a segment.
void check_time(const LogSegment& seg, const std::string& source, const std::string& column);

UnitKind drive_kind(LogQuantity q);
UnitKind response_kind(LogQuantity q);
/// The user's unit override for a kind (empty: none).
const std::string& unit_override(const LogReadOptions& o, UnitKind kind);
/// Scale of a column: the override, else the unit found in the file, else an error.
double column_scale(const LogReadOptions& o, UnitKind kind, const std::string& file_unit,
                    bool file_has_unit, const std::string& where, const std::string& column);

/// One error for every column that has neither a unit in the file nor an override:
/// each with the option that gives it.
struct UnitNeed {
  UnitKind kind;
  std::string column;
  bool has_unit;
};
void require_units(const LogReadOptions& o, const std::vector<UnitNeed>& needs, const std::string& where);

/// Fills the convenience lookups from `parameters` and checks that there is data
/// (unless `allow_empty`: inspection).
void finish(OscillationLog& log, bool allow_empty = false);

// ---- Localised column names (Anton Paar, TRIOS) -----------------------------------

/// "Interval data:" in English, German or French.
bool is_interval_marker(std::string_view first_cell);
/// A RheoCompass table header in any language: TAB cells whose first non-empty one
/// (index `first`) is an interval marker, or ends with ':' and is followed by at least
/// three column names (no numbers).
bool is_table_header(const std::vector<std::string_view>& cells, std::size_t first);
const std::vector<std::string>& time_names();
const std::vector<std::string>& angle_names();
const std::vector<std::string>& torque_names();
const std::vector<std::string>& strain_names();
const std::vector<std::string>& stress_names();

/// Index of the first header (in candidate order) whose folded name is one of the
/// candidates; `alternatives[i]` holds the names under which header i may be found.
std::optional<std::size_t> find_localised(const std::vector<std::vector<std::string>>& alts,
                                          const std::vector<std::string>& candidates);
/// Which column of a vendor table holds a quantity: the user's name if it differs
/// from the default, else the localised names.
std::optional<std::size_t> find_vendor_column(const std::vector<std::vector<std::string>>& alts,
                                              const std::string& option,
                                              const std::string& default_name,
                                              const std::vector<std::string>& candidates);

/// The time/drive/response columns of a vendor table (no time column: `time` empty).
struct VendorColumns {
  std::optional<Column> time;
  Column drive, response;
};
/// Resolves them from the names per position and the units per position ("" when absent).
VendorColumns resolve_vendor_columns(const std::vector<std::vector<std::string>>& alts,
                                     const std::vector<std::string>& units,
                                     const LogReadOptions& o, const std::string& source,
                                     std::size_t header_line);

/// A value the instrument reports beside the samples (frequency, G', torque): the
/// finite number (decimal comma allowed) of `col` times `scale`, or kUnset when the
/// column is absent, the cell empty or not a number, or the scale unset.
/// A value the instrument reported for a point (frequency, G', G'', torque): unset
/// when its column or cell is absent or empty; InputError naming the line when the
/// cell is not a finite number, or (positive) not > 0.
double instrument_value(const std::vector<std::string_view>& cells, std::optional<std::size_t> col, double scale,
                        bool positive, const char* what, const std::string& source, std::size_t line);
double cell_or_unset(const std::vector<std::string_view>& cells, std::optional<std::size_t> col,
                     double scale);
/// Factor of `unit` to SI for `kind`, kUnset when the unit is not known.
double unit_scale_or_unset(const std::string& unit, UnitKind kind);
/// The refusal of a file none of whose `blocks` tables or steps (`block_word`) holds a
/// waveform: with one block its own message `first_error`, else one line with the first
/// of log.skipped, the count of the others and `hint`.
[[noreturn]] void refuse_without_waveform(const OscillationLog& log, std::size_t blocks,
                                          const char* block_word, const std::string& first_error,
                                          const std::string& hint);

/// Records, once, that the log has no time column.
void note_no_time(OscillationLog& log);
/// Refuses the interval_column option for a vendor format that has its own segments.
void no_interval_column(const LogReadOptions& o, const char* format);

// ---- Readers (one file each) --------------------------------------------------------

void read_anton_paar(std::string_view text, const LogReadOptions& o, OscillationLog& log);  // log_anton_paar.cpp
void read_trios(std::string_view text, const LogReadOptions& o, OscillationLog& log);       // log_trios.cpp
void read_reptate(std::string_view text, const LogReadOptions& o, OscillationLog& log);     // log_reptate.cpp
void read_generic(std::string_view text, const LogReadOptions& o, OscillationLog& log);     // log_generic.cpp
void read_malvern(std::string_view text, const LogReadOptions& o, OscillationLog& log);     // log_malvern.cpp
/// The first line of a Malvern rSpace CSV: ';' cells starting with "Action Name".
bool looks_like_malvern(std::string_view first_line);

}  // namespace shearzone::io::log_detail
