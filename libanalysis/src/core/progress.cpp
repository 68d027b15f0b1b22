#include "shearzone/core/progress.hpp"

#include <unistd.h>

#include <cmath>

#include <fmt/format.h>

namespace shearzone::core {

ProgressReporter::ProgressReporter(std::string label, LogLevel level, std::FILE* stream,
                                   double min_interval_s)
    : label_(std::move(label)),
      stream_(stream),
      enabled_(level != LogLevel::kQuiet && stream != nullptr && isatty(fileno(stream)) == 1),
      min_interval_s_(min_interval_s),
      start_(std::chrono::steady_clock::now()),
      last_(start_ - std::chrono::hours(1)) {}

ProgressReporter::~ProgressReporter() { finish(); }

std::string ProgressReporter::format_line(const std::string& label, std::size_t done,
                                          std::size_t total, double elapsed_s) {
  const double rate = elapsed_s > 0 ? static_cast<double>(done) / elapsed_s : 0.0;
  std::string eta = "?";
  if (rate > 0 && total >= done) {
    const double remaining = static_cast<double>(total - done) / rate;
    eta = remaining < 120 ? fmt::format("{:.0f} s", remaining)
                          : fmt::format("{:.1f} min", remaining / 60.0);
  }
  if (total == 0) return fmt::format("{}: {} ({:.1f}/s)", label, done, rate);
  return fmt::format("{}: {}/{} ({:.1f}/s, ETA {})", label, done, total, rate, eta);
}

namespace {
thread_local ProgressObserver t_observer;
}  // namespace

ProgressObserver set_progress_observer(ProgressObserver observer) {
  std::swap(t_observer, observer);
  return observer;
}

void ProgressReporter::update(std::size_t done, std::size_t total) {
  if (t_observer) t_observer(label_, done, total);
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  const bool last_item = total > 0 && done >= total;
  if (!last_item && std::chrono::duration<double>(now - last_).count() < min_interval_s_) return;
  last_ = now;
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  const std::string line = format_line(label_, done, total, elapsed);
  std::fprintf(stream_, "\r\033[K%s", line.c_str());
  std::fflush(stream_);
  drawn_ = true;
}

void ProgressReporter::finish() {
  if (enabled_ && drawn_) {
    std::fprintf(stream_, "\r\033[K");
    std::fflush(stream_);
    drawn_ = false;
  }
}

ProgressCallback ProgressReporter::callback() {
  return [this](std::size_t done, std::size_t total) { update(done, total); };
}

}  // namespace shearzone::core
