// Rheometer oscillation logs: text decoding, format detection and dispatch to the four
// readers (log_generic.cpp, log_anton_paar.cpp, log_trios.cpp, log_reptate.cpp; shared
// pieces in log_common.hpp). Every reader produces segments of (time, drive, response)
// in SI units and checks them the same way (finite numbers, increasing time), so that
// each error names file, line, column.
#include "shearzone/io/oscillation_log.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string_view>

#include <fmt/format.h>

#include "shearzone/core/enum_names.hpp"
#include "shearzone/core/error.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/io/file.hpp"
#include "shearzone/io/units.hpp"

#include "log_common.hpp"

namespace shearzone::io {
namespace {

using namespace log_detail;

// ---- Detection ----------------------------------------------------------------------

bool has_utf16_bom(const std::string& bytes) {
  return bytes.size() >= 2 && ((static_cast<unsigned char>(bytes[0]) == 0xFF &&
                                static_cast<unsigned char>(bytes[1]) == 0xFE) ||
                               (static_cast<unsigned char>(bytes[0]) == 0xFE &&
                                static_cast<unsigned char>(bytes[1]) == 0xFF));
}

/// First line like "omega=3.0;gamma=1.0;".
bool looks_like_reptate_header(std::string_view line) {
  line = trim(line);
  const std::size_t eq = line.find('=');
  const std::size_t semi = line.find(';');
  if (eq == std::string_view::npos || semi == std::string_view::npos || eq == 0 || eq > semi)
    return false;
  for (std::size_t k = 0; k < eq; ++k) {
    const char c = line[k];
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_')) return false;
  }
  return line.find('\t') == std::string_view::npos && line.find(',') == std::string_view::npos;
}

}  // namespace

// ---- Public -----------------------------------------------------------------------

const char* log_format_name(LogFormat f) {
  switch (f) {
    case LogFormat::kAuto: return "auto";
    case LogFormat::kCsv: return "csv";
    case LogFormat::kAntonPaar: return "anton-paar";
    case LogFormat::kTrios: return "trios";
    case LogFormat::kRepTate: return "reptate";
    case LogFormat::kMalvern: return "malvern";
  }
  return "?";
}

LogFormat log_format_from_name(const std::string& name) {
  return core::enum_from_name(name,
                              {LogFormat::kAuto, LogFormat::kCsv, LogFormat::kAntonPaar, LogFormat::kTrios,
                               LogFormat::kRepTate, LogFormat::kMalvern},
                              log_format_name, "log format");
}

std::string decode_text(const std::string& bytes, const std::string& source) {
  const auto* b = reinterpret_cast<const unsigned char*>(bytes.data());
  const std::size_t n = bytes.size();
  bool utf16 = false, big_endian = false;
  std::size_t start = 0;
  if (n >= 2 && b[0] == 0xFF && b[1] == 0xFE) {
    utf16 = true;
    start = 2;
  } else if (n >= 2 && b[0] == 0xFE && b[1] == 0xFF) {
    utf16 = big_endian = true;
    start = 2;
  } else if (n >= 4 && b[0] != 0 && b[1] == 0 && b[2] != 0 && b[3] == 0) {
    utf16 = true;  // UTF-16 LE without a BOM: ASCII text with zero high bytes
  }
  if (utf16) {
    if ((n - start) % 2 != 0)
      throw InputError(fmt::format("{}: invalid UTF-16 text: odd number of bytes ({}); expected "
                                   "2 bytes per code unit",
                                   source, n));
    std::string out;
    out.reserve(n);
    auto unit = [&](std::size_t k) -> std::uint32_t {
      return big_endian ? (std::uint32_t{b[k]} << 8) | b[k + 1]
                        : (std::uint32_t{b[k + 1]} << 8) | b[k];
    };
    for (std::size_t k = start; k < n; k += 2) {
      std::uint32_t cp = unit(k);
      if (cp >= 0xD800 && cp <= 0xDBFF) {
        if (k + 2 >= n || unit(k + 2) < 0xDC00 || unit(k + 2) > 0xDFFF)
          throw InputError(fmt::format("{}: invalid UTF-16 text at byte {}: a high surrogate "
                                       "(0x{:04X}) not followed by a low surrogate",
                                       source, k, cp));
        cp = 0x10000 + ((cp - 0xD800) << 10) + (unit(k + 2) - 0xDC00);
        k += 2;
      } else if (cp >= 0xDC00 && cp <= 0xDFFF) {
        throw InputError(fmt::format("{}: invalid UTF-16 text at byte {}: a lone low surrogate "
                                     "(0x{:04X})",
                                     source, k, cp));
      }
      if (cp < 0x80) {
        out += static_cast<char>(cp);
      } else if (cp < 0x800) {
        out += static_cast<char>(0xC0 | (cp >> 6));
        out += static_cast<char>(0x80 | (cp & 0x3F));
      } else if (cp < 0x10000) {
        out += static_cast<char>(0xE0 | (cp >> 12));
        out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
        out += static_cast<char>(0x80 | (cp & 0x3F));
      } else {
        out += static_cast<char>(0xF0 | (cp >> 18));
        out += static_cast<char>(0x80 | ((cp >> 12) & 0x3F));
        out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
        out += static_cast<char>(0x80 | (cp & 0x3F));
      }
    }
    return out;
  }
  if (n >= 3 && b[0] == 0xEF && b[1] == 0xBB && b[2] == 0xBF) start = 3;
  // Valid UTF-8 is kept; anything else is read as Latin-1 (ISO 8859-1: older
  // exports write "µ" and "°" as the single bytes 0xB5 and 0xB0).
  bool valid = true;
  for (std::size_t k = start; k < n && valid;) {
    const unsigned char c = b[k];
    std::size_t len = c < 0x80 ? 1 : (c >> 5) == 6 ? 2 : (c >> 4) == 14 ? 3 : (c >> 3) == 30 ? 4 : 0;
    if (len == 0 || k + len > n) {
      valid = false;
      break;
    }
    for (std::size_t j = 1; j < len; ++j) valid &= (b[k + j] & 0xC0) == 0x80;
    k += len;
  }
  if (valid) return bytes.substr(start);
  std::string out;
  for (std::size_t k = start; k < n; ++k) {
    const unsigned char c = b[k];
    if (c < 0x80) {
      out += static_cast<char>(c);
    } else {
      out += static_cast<char>(0xC0 | (c >> 6));
      out += static_cast<char>(0x80 | (c & 0x3F));
    }
  }
  return out;
}

OscillationLog read_oscillation_log(const std::filesystem::path& path,
                                    const LogReadOptions& options) {
  const std::string bytes = read_file_bytes(path, "log file");
  OscillationLog log;
  log.source = path.string();
  log.quantity = options.quantity;
  const std::string text = decode_text(bytes, log.source);
  // A byte-order mark after the start (U+FEFF, once decoded) is damage: files pasted
  // together, or a cell edited in another program. It split a Malvern action in two
  // and made a number cell unreadable; refused with its line.
  if (const std::size_t bom = text.find("\xEF\xBB\xBF"); bom != std::string::npos)
    throw InputError(fmt::format("{}:{}: a byte-order mark (U+FEFF) inside the file; expected one at its start "
                                 "only (files pasted together, or a cell edited elsewhere)",
                                 log.source, 1 + std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(bom), '\n')));

  LogFormat format = options.format;
  if (format == LogFormat::kAuto) {
    const auto lines = split_lines(text);
    bool interval_marker = false, section = false, tab_pairs = false;
    for (const auto& l : lines) {
      const auto cells = split_cells(l.text, '\t');
      std::size_t f = 0;
      while (f < cells.size() && cells[f].empty()) ++f;
      if (f < cells.size() && is_table_header(cells, f)) interval_marker = true;
      if (is_section_header(l.text)) section = true;
      if (cells.size() >= 2 && !cells[0].empty() && !is_number(cells[0])) tab_pairs = true;
      // TRIOS's CSV export: the same name/value lines, comma-separated.
      if (l.text.find('\t') == std::string_view::npos) {
        const auto cc = split_cells(l.text, ',');
        if (cc.size() == 2 && !cc[0].empty() && !is_number(cc[0])) tab_pairs = true;
      }
    }
    std::string_view first_line;
    for (const auto& l : lines)
      if (!trim(l.text).empty()) {
        first_line = l.text;
        break;
      }
    if (interval_marker) {
      format = LogFormat::kAntonPaar;
    } else if (section && tab_pairs) {
      format = LogFormat::kTrios;
    } else if (has_utf16_bom(bytes)) {
      format = LogFormat::kAntonPaar;
    } else if (looks_like_malvern(first_line)) {
      format = LogFormat::kMalvern;
    } else if (path.extension() == ".laos" || looks_like_reptate_header(first_line)) {
      format = LogFormat::kRepTate;
    } else {
      format = LogFormat::kCsv;
    }
  }
  log.format = format;
  switch (format) {
    case LogFormat::kAntonPaar: read_anton_paar(text, options, log); break;
    case LogFormat::kTrios: read_trios(text, options, log); break;
    case LogFormat::kRepTate: read_reptate(text, options, log); break;
    case LogFormat::kMalvern: read_malvern(text, options, log); break;
    case LogFormat::kCsv:
    case LogFormat::kAuto: read_generic(text, options, log); break;
  }
  finish(log, options.inspect);
  return log;
}

}  // namespace shearzone::io
