#include "shearzone/io/video.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <atomic>
#include <cstdarg>
#include <fstream>
#include <string_view>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

extern "C" {
#include <libavutil/log.h>
}

#include "shearzone/core/error.hpp"
#include "shearzone/io/file.hpp"
#include "shearzone/io/image.hpp"
#include "stderr_silencer.hpp"

namespace shearzone::io {
namespace {

std::string fourcc_text(double v) {
  const int code = static_cast<int>(v);
  std::string s;
  for (int i = 0; i < 4; ++i) {
    const char c = static_cast<char>((code >> (8 * i)) & 0xFF);
    s += std::isprint(static_cast<unsigned char>(c)) ? c : '?';
  }
  return s;
}

}  // namespace

bool is_video_extension(const std::filesystem::path& path) {
  for (const char* x : {".mp4", ".avi", ".mov", ".mkv"})
    if (has_extension(path, x)) return true;
  return false;
}

namespace {

// FFmpeg reports decode errors only through its log. Every message at AV_LOG_ERROR or
// worse is counted (and none is printed): a read() during which the count grows
// returned a frame FFmpeg had to conceal, i.e. a damaged frame.
std::atomic<std::int64_t> g_ffmpeg_errors{0};

void count_ffmpeg_log(void*, int level, const char*, va_list) {
  if (level <= AV_LOG_ERROR) g_ffmpeg_errors.fetch_add(1, std::memory_order_relaxed);
}

}  // namespace

bool looks_like_video(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  char h[12] = {};
  in.read(h, sizeof(h));
  if (in.gcount() < 12) return false;
  const std::string_view b(h, 12);
  auto u = [&](std::size_t i) { return static_cast<unsigned char>(b[i]); };
  return b.compare(4, 4, "ftyp") == 0 || (b.compare(0, 4, "RIFF") == 0 && b.compare(8, 4, "AVI ") == 0) ||
         (u(0) == 0x1A && u(1) == 0x45 && u(2) == 0xDF && u(3) == 0xA3);
}

VideoReader::VideoReader(const std::filesystem::path& path) : path_(path.string()) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw InputError(fmt::format("{}: no such file", path_));
  cap_ = std::make_unique<cv::VideoCapture>();
  av_log_set_callback(count_ffmpeg_log);  // no FFmpeg line on stderr, errors counted
  try {
    cap_->open(path_, cv::CAP_FFMPEG);
  } catch (const cv::Exception& e) {
    throw InputError(fmt::format("{}: cannot open video: {}", path_, e.what()));
  }
  if (!cap_->isOpened())
    throw InputError(fmt::format("{}: cannot open as video (not a video, unsupported codec, or "
                                 "truncated before the index)",
                                 path_));
  info_.fps = cap_->get(cv::CAP_PROP_FPS);
  info_.frame_count = static_cast<std::int64_t>(std::llround(cap_->get(cv::CAP_PROP_FRAME_COUNT)));
  info_.width = static_cast<int>(cap_->get(cv::CAP_PROP_FRAME_WIDTH));
  info_.height = static_cast<int>(cap_->get(cv::CAP_PROP_FRAME_HEIGHT));
  info_.codec = fourcc_text(cap_->get(cv::CAP_PROP_FOURCC));
  if (!(info_.fps > 0) || !std::isfinite(info_.fps))
    throw InputError(fmt::format("{}: container declares fps = {}; expected a positive frame rate",
                                 path_, info_.fps));
  if (info_.width <= 0 || info_.height <= 0)
    throw InputError(fmt::format("{}: video has no frames of a known size", path_));
  check_image_size(info_.width, info_.height, path_);
}

VideoReader::~VideoReader() = default;

bool VideoReader::read(cv::Mat& gray, double& t_s) {
  cv::Mat frame;
  bool ok = false;
  av_log_set_callback(count_ffmpeg_log);  // OpenCV may have installed its own at open
  const std::int64_t errors_before = g_ffmpeg_errors.load();
  try {
    ok = cap_->read(frame);
  } catch (const cv::Exception& e) {
    throw InputError(fmt::format("{}: frame {}: cannot decode: {}", path_, next_, e.what()));
  }
  if (!ok || frame.empty()) {
    if (info_.frame_count > 0 && next_ < info_.frame_count)
      throw InputError(fmt::format("{}: frame {}: cannot decode; the container declares {} "
                                   "frames (truncated or corrupt file?)",
                                   path_, next_, info_.frame_count));
    return false;
  }
  if (frame.size() != cv::Size(info_.width, info_.height))
    throw InputError(fmt::format("{}: frame {}: size {}x{} differs from the first frame's {}x{}",
                                 path_, next_, frame.cols, frame.rows, info_.width,
                                 info_.height));
  // The FFmpeg back-end reports the presentation time of the frame just read, except for
  // the frames an H.264 decoder still holds at the end of the stream (B-frame delay):
  // OpenCV 4.6 reports 0 for those. A time that does not move forward is such a gap:
  // the frame follows the previous one by 1/fps.
  t_s = cap_->get(cv::CAP_PROP_POS_MSEC) / 1000.0;
  if (!std::isfinite(t_s) || t_s < 0) t_s = static_cast<double>(next_) / info_.fps;
  if (next_ > 0 && !(t_s > last_t_s_)) t_s = last_t_s_ + 1.0 / info_.fps;
  last_t_s_ = t_s;
  gray = frame.depth() == CV_8U ? to_gray(frame, grey_mode_) : cv::Mat();
  if (gray.empty())
    throw InputError(fmt::format("{}: frame {}: unsupported sample depth; expected 8-bit video",
                                 path_, next_));
  last_damaged_ = g_ffmpeg_errors.load() != errors_before;
  damaged_ += last_damaged_;
  ++next_;
  return true;
}

VideoWriter::VideoWriter(const std::filesystem::path& path, double fps, cv::Size size,
                         const std::string& codec)
    : path_(path.string()), size_(size) {
  if (codec.size() != 4)
    throw ConfigError(fmt::format("video codec \"{}\": expected a four-character code such as "
                                  "mp4v, avc1 or MJPG",
                                  codec));
  if (!(fps > 0)) throw ConfigError(fmt::format("video fps = {}: must be > 0", fps));
  writer_ = std::make_unique<cv::VideoWriter>();
  const int fourcc = cv::VideoWriter::fourcc(codec[0], codec[1], codec[2], codec[3]);
  bool ok = false;
  try {
    // OpenCV prints "FFMPEG: tag ... is not found" straight to stderr: our line says it.
    const detail::StderrSilencer quiet;
    ok = writer_->open(path_, cv::CAP_FFMPEG, fourcc, fps, size, false);
  } catch (const cv::Exception& e) {
    ok = false;
  }
  if (!ok)
    throw ConfigError(fmt::format("{}: cannot open a video writer for codec \"{}\" (this "
                                  "OpenCV/FFmpeg build may lack it; try mp4v for .mp4 or MJPG "
                                  "for .avi)",
                                  path_, codec));
}

VideoWriter::~VideoWriter() = default;

void VideoWriter::write(const cv::Mat& gray8) {
  if (gray8.type() != CV_8UC1 || gray8.size() != size_)
    throw InternalError(fmt::format("{}: VideoWriter::write expects {}x{} CV_8UC1 frames", path_,
                                    size_.width, size_.height));
  writer_->write(gray8);
}

void VideoWriter::close() {
  if (writer_) writer_->release();
}

}  // namespace shearzone::io
