// shearzone/core/progress.hpp: progress reporting for long work.
//
// Library functions that take long accept a `ProgressCallback` and call it with
// (items done, items total); they never print. The CLI passes a ProgressReporter,
// which draws `label: 37/100 (12.3/s, ETA 5 s)` on one terminal line, and only when
// its stream is a terminal: redirected to a file or a pipe, it stays quiet.
// Not thread-safe: call update() from one thread (library code calls the callback
// from the calling thread only).
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdio>
#include <functional>
#include <string>

namespace shearzone::core {

using ProgressCallback = std::function<void(std::size_t done, std::size_t total)>;

/// Verbosity of the CLI's stderr messages (-q, default, -v).
enum class LogLevel { kQuiet = 0, kNormal = 1, kVerbose = 2 };

/// Sees every reporter's update on its thread: (label, done, total).
using ProgressObserver = std::function<void(const std::string& label, std::size_t done, std::size_t total)>;

/// Every ProgressReporter updated on this thread also calls `observer` (empty: none),
/// drawing or not: the Python module's progress callback and its Ctrl-C check (an
/// observer may throw to stop the work). Returns the observer it replaces.
ProgressObserver set_progress_observer(ProgressObserver observer);

class ProgressReporter {
 public:
  /// Draws on `stream` (stderr by default) only if it is a terminal and `level` is
  /// not kQuiet. `min_interval_s` throttles redraws.
  explicit ProgressReporter(std::string label, LogLevel level = LogLevel::kNormal,
                            std::FILE* stream = stderr, double min_interval_s = 0.1);
  ~ProgressReporter();
  ProgressReporter(const ProgressReporter&) = delete;
  ProgressReporter& operator=(const ProgressReporter&) = delete;

  void update(std::size_t done, std::size_t total);
  /// Clears the line (if anything was drawn). Called by the destructor.
  void finish();
  /// A callback bound to this reporter (the reporter must outlive it).
  ProgressCallback callback();
  bool enabled() const { return enabled_; }

  /// The text that would be drawn; exposed for tests.
  static std::string format_line(const std::string& label, std::size_t done, std::size_t total,
                                 double elapsed_s);

 private:
  std::string label_;
  std::FILE* stream_;
  bool enabled_;
  bool drawn_ = false;
  double min_interval_s_;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_;
};

}  // namespace shearzone::core
