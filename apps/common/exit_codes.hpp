// apps/common/exit_codes.hpp: the exit codes of `shearzone` (README, "Exit codes").
#pragma once

namespace shearzone::apps {

inline constexpr int kExitOk = 0;            ///< success
inline constexpr int kExitUsage = 1;         ///< bad flag or argument (every CLI11 parse error)
inline constexpr int kExitInputError = 2;    ///< bad input or configuration (InputError, ConfigError)
inline constexpr int kExitNoResult = 3;      ///< ran, but no usable result
inline constexpr int kExitInternal = 4;      ///< internal error (a bug, or an unexpected exception)
// Killed by SIGINT/SIGTERM: the shell reports 128 + signal (130 for Ctrl-C); no
// partial output is left behind.

}  // namespace shearzone::apps
