// Private to io: silences file descriptor 2 around third-party calls that print
// (libpng, OpenCV's FFmpeg back-end) so that a failure reads as one shearzone line.
#pragma once

#include <fcntl.h>
#include <unistd.h>

#include <cstdio>

namespace shearzone::io::detail {

/// Redirects file descriptor 2 to /dev/null for its lifetime. Used on one thread at a
/// time (the frame readers decode serially; writers are opened once).
class StderrSilencer {
 public:
  StderrSilencer() {
    std::fflush(stderr);
    saved_ = ::dup(2);
    const int null = ::open("/dev/null", O_WRONLY);
    if (saved_ >= 0 && null >= 0) ::dup2(null, 2);
    if (null >= 0) ::close(null);
  }
  ~StderrSilencer() {
    std::fflush(stderr);
    if (saved_ >= 0) {
      ::dup2(saved_, 2);
      ::close(saved_);
    }
  }
  StderrSilencer(const StderrSilencer&) = delete;
  StderrSilencer& operator=(const StderrSilencer&) = delete;

 private:
  int saved_ = -1;
};

}  // namespace shearzone::io::detail
