// Shared helpers of the libFuzzer targets: inputs that readers take as files are
// written to one temporary file per process, and every toolkit error is an expected
// outcome (the fuzzer looks for crashes, hangs, leaks and undefined behaviour).
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "shearzone/io/image.hpp"

namespace shearzone::fuzz {

/// The decoder settings of the CLI (log levels, OpenCV's pixel limit), before any input.
inline const bool kDecodersConfigured = (io::configure_decoders(), true);

/// A per-process temporary path with the given extension (the readers look at it).
inline std::filesystem::path temp_path(const std::string& extension) {
  return std::filesystem::temp_directory_path() /
         ("shearzone-fuzz-" + std::to_string(::getpid()) + extension);
}

inline std::filesystem::path write_temp(const std::uint8_t* data, std::size_t size,
                                        const std::string& extension) {
  const auto p = temp_path(extension);
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return p;
}

}  // namespace shearzone::fuzz
