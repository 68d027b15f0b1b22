#include "shearzone/core/check.hpp"

#include <filesystem>

namespace shearzone::detail {

void check_failed(const char* file, int line, const std::string& what) {
  throw InternalError("internal check failed at " +
                      std::filesystem::path(file).filename().string() + ":" +
                      std::to_string(line) + ": " + what +
                      " (this is a bug in shearzone; please report it)");
}

}  // namespace shearzone::detail
