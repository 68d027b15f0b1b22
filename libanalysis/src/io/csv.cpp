// CSV parsing: a small RFC 4180 state machine over the whole text, tracking line
// numbers so that every error can name the line it is about.
#include "shearzone/io/csv.hpp"

#include <algorithm>
#include <charconv>
#include <unordered_set>
#include <cmath>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/io/file.hpp"

namespace shearzone::io {

std::string_view trim_blanks(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

namespace {

/// One physical line of the text, for the comment/blank-line checks.
std::string_view line_at(std::string_view text, std::size_t pos) {
  std::size_t end = text.find_first_of("\r\n", pos);
  if (end == std::string_view::npos) end = text.size();
  return text.substr(pos, end - pos);
}

/// Moves `pos` past the line break at `pos` (\n, \r\n or \r).
void skip_newline(std::string_view text, std::size_t& pos) {
  if (pos < text.size() && text[pos] == '\r') ++pos;
  if (pos < text.size() && text[pos] == '\n') ++pos;
}

char detect_separator(std::string_view header) {
  bool in_quotes = false;
  bool has_tab = false, has_semicolon = false;
  for (char c : header) {
    if (c == '"') in_quotes = !in_quotes;
    if (in_quotes) continue;
    has_tab |= c == '\t';
    has_semicolon |= c == ';';
  }
  if (has_tab) return '\t';
  if (has_semicolon) return ';';
  return ',';
}

/// Parses one record starting at `pos`; advances `pos` and `line`.
std::vector<std::string> parse_record(std::string_view text, std::size_t& pos, std::size_t& line,
                                      char sep, const std::string& source) {
  std::vector<std::string> fields;
  std::string field;
  const std::size_t start_line = line;
  while (true) {
    if (pos < text.size() && text[pos] == '"' && trim_blanks(field).empty()) {
      // Quoted field.
      field.clear();
      ++pos;
      while (true) {
        if (pos >= text.size())
          throw InputError(fmt::format("{}:{}: unterminated quoted field (a '\"' opened here is "
                                       "never closed)",
                                       source, start_line));
        char c = text[pos];
        if (c == '"') {
          if (pos + 1 < text.size() && text[pos + 1] == '"') {
            field += '"';
            pos += 2;
            continue;
          }
          ++pos;
          break;
        }
        if (c == '\r' || c == '\n') {
          skip_newline(text, pos);
          field += '\n';
          ++line;
          continue;
        }
        field += c;
        ++pos;
      }
      // After the closing quote: separator, end of line or end of text.
      while (pos < text.size() && (text[pos] == ' ' || text[pos] == '\t') && text[pos] != sep)
        ++pos;
      if (pos < text.size() && text[pos] != sep && text[pos] != '\r' && text[pos] != '\n')
        throw InputError(fmt::format(
            "{}:{}: unexpected character '{}' after a closing quote; expected the separator "
            "'{}' or the end of the line",
            source, line, text[pos], sep == '\t' ? std::string("\\t") : std::string(1, sep)));
      fields.push_back(field);
      field.clear();
    } else {
      // Unquoted field: up to the separator or the end of the line.
      while (pos < text.size() && text[pos] != sep && text[pos] != '\r' && text[pos] != '\n') {
        if (text[pos] == '"')
          throw InputError(fmt::format(
              "{}:{}: stray '\"' inside an unquoted field; expected the whole field quoted "
              "(RFC 4180)",
              source, line));
        field += text[pos++];
      }
      fields.emplace_back(trim_blanks(field));
      field.clear();
    }
    if (pos < text.size() && text[pos] == sep) {
      ++pos;
      continue;
    }
    skip_newline(text, pos);
    ++line;
    return fields;
  }
}

}  // namespace

bool parse_number(std::string_view text, bool decimal_comma, double& value) {
  text = trim_blanks(text);
  if (text.empty()) return false;
  std::string buf(text);
  if (decimal_comma) std::replace(buf.begin(), buf.end(), ',', '.');
  const char* first = buf.data();
  const char* last = buf.data() + buf.size();
  if (*first == '+') ++first;  // from_chars does not accept a leading '+'
  auto [ptr, ec] = std::from_chars(first, last, value);
  return ec == std::errc() && ptr == last;
}

CsvTable parse_csv(std::string_view text, const std::string& source) {
  CsvTable t;
  t.source = source;
  // Byte-order mark.
  if (text.size() >= 3 && static_cast<unsigned char>(text[0]) == 0xEF &&
      static_cast<unsigned char>(text[1]) == 0xBB && static_cast<unsigned char>(text[2]) == 0xBF)
    text.remove_prefix(3);

  std::size_t pos = 0, line = 1;
  // Leading comment block and blank lines.
  while (pos < text.size()) {
    std::string_view l = line_at(text, pos);
    std::string_view tl = trim_blanks(l);
    if (tl.empty() || tl.front() == '#') {
      if (!tl.empty()) {
        std::string_view body = trim_blanks(tl.substr(1));
        const std::size_t colon = body.find(':');
        if (colon != std::string_view::npos && colon > 0)
          t.metadata.emplace_back(std::string(trim_blanks(body.substr(0, colon))),
                                  std::string(trim_blanks(body.substr(colon + 1))));
      }
      pos += l.size();
      skip_newline(text, pos);
      ++line;
      continue;
    }
    break;
  }
  if (pos >= text.size())
    throw InputError(fmt::format("{}: no header row found; expected a row of column names "
                                 "after the '#' comment lines",
                                 source));

  t.separator = detect_separator(line_at(text, pos));
  t.decimal_comma = t.separator != ',';
  t.header_line = line;
  t.columns = parse_record(text, pos, line, t.separator, source);
  std::unordered_set<std::string_view> seen;  // linear: a header may hold 1e6 names
  for (std::size_t i = 0; i < t.columns.size(); ++i) {
    if (t.columns[i].empty())
      throw InputError(fmt::format("{}:{}: column {} of the header row has no name", source,
                                   t.header_line, i + 1));
    if (!seen.insert(t.columns[i]).second)
      throw InputError(fmt::format("{}:{}: column name \"{}\" appears twice in the header row",
                                   source, t.header_line, excerpt(t.columns[i], 60)));
  }

  while (pos < text.size()) {
    std::string_view l = line_at(text, pos);
    if (trim_blanks(l).empty()) {  // blank line
      pos += l.size();
      skip_newline(text, pos);
      ++line;
      continue;
    }
    const std::size_t row_line = line;
    auto fields = parse_record(text, pos, line, t.separator, source);
    if (fields.size() != t.columns.size())
      throw InputError(fmt::format(
          "{}:{}: row has {} field{}; expected {} as in the header row (line {})", source,
          row_line, fields.size(), fields.size() == 1 ? "" : "s", t.columns.size(),
          t.header_line));
    t.rows.push_back(std::move(fields));
    t.row_lines.push_back(row_line);
  }
  return t;
}

CsvTable read_csv(const std::filesystem::path& path) {
  return parse_csv(read_file_bytes(path, "file"), path.string());
}

bool CsvTable::has_column(std::string_view name) const {
  return std::find(columns.begin(), columns.end(), name) != columns.end();
}

std::size_t CsvTable::column_index(std::string_view name) const {
  auto it = std::find(columns.begin(), columns.end(), name);
  if (it == columns.end()) {
    std::string have;
    for (const auto& c : columns) have += (have.empty() ? "" : ", ") + c;
    throw InputError(fmt::format("{}:{}: missing column \"{}\"; the header has: {}", source,
                                 header_line, excerpt(name), excerpt(have, 300)));
  }
  return static_cast<std::size_t>(it - columns.begin());
}

double CsvTable::number(std::size_t row, std::size_t col, bool require_finite) const {
  const std::string& cell = rows.at(row).at(col);
  double v = 0;
  if (!parse_number(cell, decimal_comma, v)) {
    if (trim_blanks(cell).empty())
      throw InputError(fmt::format("{}:{}: column \"{}\": empty cell; expected a number",
                                   source, row_lines[row], excerpt(columns[col], 60)));
    throw InputError(fmt::format("{}:{}: column \"{}\": \"{}\" is not a number", source,
                                 row_lines[row], excerpt(columns[col], 60), excerpt(cell)));
  }
  if (require_finite && !std::isfinite(v))
    throw InputError(fmt::format("{}:{}: column \"{}\": \"{}\" is not a finite number", source,
                                 row_lines[row], excerpt(columns[col], 60), excerpt(cell)));
  return v;
}

std::string excerpt(std::string_view text, std::size_t max_chars) {
  if (text.size() <= max_chars) return std::string(text);
  return fmt::format("{}... ({} more characters)", text.substr(0, max_chars), text.size() - max_chars);
}

bool CsvTable::cell_empty(std::size_t row, std::size_t col) const {
  return trim_blanks(rows.at(row).at(col)).empty();
}

std::vector<double> CsvTable::numeric_column(std::string_view name, bool require_finite) const {
  const std::size_t c = column_index(name);
  std::vector<double> out(rows.size());
  for (std::size_t r = 0; r < rows.size(); ++r) out[r] = number(r, c, require_finite);
  return out;
}

std::vector<std::string> CsvTable::text_column(std::string_view name) const {
  const std::size_t c = column_index(name);
  std::vector<std::string> out(rows.size());
  for (std::size_t r = 0; r < rows.size(); ++r) out[r] = rows[r][c];
  return out;
}

// ---- Writer -----------------------------------------------------------------------

namespace {
/// Shortest text that reads back to exactly `value` (std::to_chars round trip).
template <class T>
std::string shortest_text(T value, const char* fallback_format) {
  if (std::isnan(value)) return "nan";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  char buf[64];
  auto [ptr, ec] = std::to_chars(buf, buf + sizeof(buf), value);
  if (ec != std::errc()) return fmt::format(fmt::runtime(fallback_format), value);
  return std::string(buf, ptr);
}
}  // namespace

std::string format_number(double value) { return shortest_text(value, "{:.17g}"); }

std::string format_number_or_empty(double value) {
  return std::isfinite(value) ? format_number(value) : std::string();
}

std::string format_number_nan_empty(double value) {
  return std::isnan(value) ? std::string() : format_number(value);
}

std::string CsvWriter::format_number(double value) { return io::format_number(value); }

std::string CsvWriter::format_float(float value) { return shortest_text(value, "{:.9g}"); }

std::string CsvWriter::quote(std::string_view field, char separator) {
  const bool needs = field.find_first_of(std::string{'"', '\r', '\n', separator}) !=
                         std::string_view::npos ||
                     (!field.empty() && (field.front() == ' ' || field.back() == ' ' ||
                                         field.front() == '#'));
  if (!needs) return std::string(field);
  std::string out = "\"";
  for (char c : field) {
    if (c == '"') out += '"';
    out += c;
  }
  out += '"';
  return out;
}

CsvWriter::CsvWriter(std::ostream& out, const core::Metadata& metadata,
                     const std::vector<std::string>& columns)
    : out_(out), num_columns_(columns.size()) {
  for (const auto& [key, value] : metadata) {
    std::string v = value;
    std::replace(v.begin(), v.end(), '\n', ' ');
    std::replace(v.begin(), v.end(), '\r', ' ');
    out_ << "# " << key << ": " << v << "\n";
  }
  row(columns);
}

void CsvWriter::row(const std::vector<std::string>& cells) {
  if (cells.size() != num_columns_)
    throw InternalError(fmt::format("CsvWriter: row has {} cells, header has {}", cells.size(),
                                    num_columns_));
  for (std::size_t i = 0; i < cells.size(); ++i) {
    if (i) out_ << ',';
    out_ << quote(cells[i]);
  }
  out_ << '\n';
}

void CsvWriter::row(const std::vector<double>& values) {
  if (values.size() != num_columns_)
    throw InternalError(fmt::format("CsvWriter: row has {} values, header has {}",
                                    values.size(), num_columns_));
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (i) out_ << ',';
    out_ << format_number(values[i]);
  }
  out_ << '\n';
}

}  // namespace shearzone::io
