// libFuzzer target: the CSV reader (every table the toolkit reads: PIV pairs,
// profiles, widths, fit tables, logs in CSV form).
#include <string_view>

#include "fuzz_util.hpp"
#include "shearzone/core/error.hpp"
#include "shearzone/io/csv.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace shearzone;
  try {
    const io::CsvTable t =
        io::parse_csv(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.csv");
    for (const auto& c : t.columns) {
      try {
        (void)t.numeric_column(c);
      } catch (const Error&) {
      }
    }
    (void)t.column_index("r_m");
  } catch (const Error&) {
  }
  return 0;
}
