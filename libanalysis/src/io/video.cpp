#include "shearzone/io/video.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <atomic>
#include <cstdarg>
#include <fstream>
#include <mutex>
#include <optional>
#include <tuple>
#include <utility>
#include <vector>
#include <string_view>

#include <fmt/format.h>
#include <malloc.h>
#include <sched.h>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/frame.h>
#include <libavutil/log.h>
#include <libswscale/swscale.h>
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

/// The clock of an MP4/MOV's first video track, as its tables state it: the sample
/// count (stsz), the media time scale and duration (mdhd) and the sample deltas (stts).
struct Mp4Clock {
  std::uint64_t samples = 0, timescale = 0, duration = 0, stts_sum = 0;
  std::uint64_t zero_deltas = 0;  ///< samples (but the last) whose time does not advance
};

std::uint64_t be(const std::string& b, std::size_t at, int bytes) {
  std::uint64_t v = 0;
  for (int k = 0; k < bytes; ++k) v = (v << 8) | static_cast<unsigned char>(b[at + static_cast<std::size_t>(k)]);
  return v;
}

/// The boxes of b[from, to): (type, payload start, payload end); stops at a malformed box.
std::vector<std::tuple<std::string, std::size_t, std::size_t>> boxes(const std::string& b, std::size_t from,
                                                                     std::size_t to) {
  std::vector<std::tuple<std::string, std::size_t, std::size_t>> out;
  while (from + 8 <= to) {
    std::uint64_t size = be(b, from, 4);
    std::size_t head = 8;
    if (size == 1) {
      if (from + 16 > to) break;
      size = be(b, from + 8, 8);
      head = 16;
    } else if (size == 0) {
      size = to - from;
    }
    if (size < head || size > to - from) break;
    out.emplace_back(b.substr(from + 4, 4), from + head, from + static_cast<std::size_t>(size));
    from += static_cast<std::size_t>(size);
  }
  return out;
}

/// The first video track's clock of an MP4/MOV (ISO base media) file; nullopt for other
/// containers, a fragmented file (no sample table) or tables it cannot read.
std::optional<Mp4Clock> read_mp4_clock(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  // The top-level boxes: find moov (at the start or the end), at most 64 MiB of it.
  std::uint64_t at = 0;
  std::string moov;
  for (int guard = 0; guard < 1024 && in; ++guard) {
    char h[16];
    in.seekg(static_cast<std::streamoff>(at));
    if (!in.read(h, 8)) break;
    const std::string hs(h, 8);
    std::uint64_t size = be(hs, 0, 4);
    if (size == 1) {
      if (!in.read(h + 8, 8)) break;
      size = be(std::string(h, 16), 8, 8);
    }
    if (size < 8) break;  // 0 (to the end of file) or malformed: no moov after it
    if (hs.compare(4, 4, "moov") == 0) {
      if (size > (64U << 20)) return std::nullopt;
      moov.resize(static_cast<std::size_t>(size));
      in.seekg(static_cast<std::streamoff>(at));
      if (!in.read(moov.data(), static_cast<std::streamsize>(size))) return std::nullopt;
      break;
    }
    at += size;
  }
  if (moov.empty()) return std::nullopt;
  auto child = [&](std::size_t from, std::size_t to, const char* type) -> std::optional<std::pair<std::size_t, std::size_t>> {
    for (const auto& [t, a, b] : boxes(moov, from, to))
      if (t == type) return std::pair{a, b};
    return std::nullopt;
  };
  for (const auto& [type, ta, tb] : boxes(moov, 8, moov.size())) {
    if (type != "trak") continue;
    const auto mdia = child(ta, tb, "mdia");
    if (!mdia) continue;
    const auto hdlr = child(mdia->first, mdia->second, "hdlr");
    if (!hdlr || hdlr->second - hdlr->first < 12 || moov.compare(hdlr->first + 8, 4, "vide") != 0) continue;
    const auto mdhd = child(mdia->first, mdia->second, "mdhd");
    const auto minf = child(mdia->first, mdia->second, "minf");
    if (!mdhd || !minf) return std::nullopt;
    const auto stbl = child(minf->first, minf->second, "stbl");
    if (!stbl) return std::nullopt;
    const auto stts = child(stbl->first, stbl->second, "stts");
    const auto stsz = child(stbl->first, stbl->second, "stsz");
    if (!stts || !stsz) return std::nullopt;
    Mp4Clock c;
    const std::size_t m = mdhd->first;
    const bool v1 = moov[m] == 1;
    if (mdhd->second - m < (v1 ? 32U : 20U)) return std::nullopt;
    c.timescale = be(moov, m + (v1 ? 20 : 12), 4);
    c.duration = be(moov, m + (v1 ? 24 : 16), v1 ? 8 : 4);
    if (stsz->second - stsz->first < 12) return std::nullopt;
    c.samples = be(moov, stsz->first + 8, 4);
    const std::uint64_t entries = be(moov, stts->first + 4, 4);
    if (stts->second - stts->first < 8 + 8 * entries) return std::nullopt;
    std::uint64_t seen = 0;
    for (std::uint64_t e = 0; e < entries; ++e) {
      const std::uint64_t count = be(moov, stts->first + 8 + 8 * e, 4), delta = be(moov, stts->first + 12 + 8 * e, 4);
      c.stts_sum += count * delta;
      if (delta == 0) c.zero_deltas += (e + 1 == entries) ? count - 1 : count;  // the last sample may end at 0
      seen += count;
    }
    if (c.samples == 0 || seen != c.samples || c.timescale == 0) return std::nullopt;  // fragmented or odd
    return c;
  }
  return std::nullopt;
}

}  // namespace

/// One video stream decoded by libavcodec on the calling thread only. OpenCV 4.6 opens
/// its decoder with one thread per CPU (frame threading) and offers no option to change
/// that; on a damaged stream the threads' concealment, and which read() the decoder's
/// error lines fall into, then vary from run to run. Decoded on one thread, the same
/// file gives the same frames, the same damaged flags and the same times on every run
/// and machine. Frames are converted to BGR as OpenCV converts them (swscale, bicubic,
/// over the coded size, then cropped), so an intact file gives OpenCV's own pixels.
class VideoReader::Decoder {
 public:
  explicit Decoder(const std::string& path) : path_(path) {
    try {
      open();
    } catch (...) {
      release();  // the destructor does not run for a constructor that throws
      throw;
    }
  }
  ~Decoder() { release(); }
  Decoder(const Decoder&) = delete;
  Decoder& operator=(const Decoder&) = delete;

  /// The next frame in display order as BGR, its presentation time in s (NaN when the
  /// stream gives none) and whether the decoder reported an error or concealed while
  /// making it. False at the end of the stream.
  bool next(cv::Mat& bgr, double& t_s, bool& damaged);

 private:
  void open() {
    const std::string& path = path_;
    if (avformat_open_input(&fmt_, path.c_str(), nullptr, nullptr) < 0) {
      fmt_ = nullptr;
      throw InputError(fmt::format("{}: cannot open as video", path));
    }
    if (avformat_find_stream_info(fmt_, nullptr) < 0)
      throw InputError(fmt::format("{}: cannot read the container's stream information", path));
    const AVCodec* codec = nullptr;
    stream_ = av_find_best_stream(fmt_, AVMEDIA_TYPE_VIDEO, -1, -1, &codec, 0);
    if (stream_ < 0 || codec == nullptr)
      throw InputError(fmt::format("{}: no video stream this FFmpeg build can decode", path));
    ctx_ = avcodec_alloc_context3(codec);
    packet_ = av_packet_alloc();
    frame_ = av_frame_alloc();
    bgr_ = av_frame_alloc();
    if (ctx_ == nullptr || packet_ == nullptr || frame_ == nullptr || bgr_ == nullptr)
      throw InternalError(fmt::format("{}: cannot allocate the decoder", path));
    const AVStream* st = fmt_->streams[stream_];
    if (avcodec_parameters_to_context(ctx_, st->codecpar) < 0)
      throw InputError(fmt::format("{}: the video stream's parameters are not usable", path));
    ctx_->thread_count = 1;  // the point of this class: one thread, the same frames every run
    ctx_->thread_type = 0;
    ctx_->pkt_timebase = st->time_base;
    if (avcodec_open2(ctx_, codec, nullptr) < 0)
      throw InputError(fmt::format("{}: cannot open the decoder for the video stream", path));
    time_base_ = av_q2d(st->time_base);
    start_ = st->start_time == AV_NOPTS_VALUE ? 0 : st->start_time;
  }
  void release() {
    sws_freeContext(sws_);
    sws_ = nullptr;
    av_frame_free(&frame_);
    av_frame_free(&bgr_);
    av_packet_free(&packet_);
    avcodec_free_context(&ctx_);
    if (fmt_ != nullptr) avformat_close_input(&fmt_);
  }
  void to_bgr(cv::Mat& bgr);

  std::string path_;
  AVFormatContext* fmt_ = nullptr;
  AVCodecContext* ctx_ = nullptr;
  AVPacket* packet_ = nullptr;
  AVFrame* frame_ = nullptr;
  AVFrame* bgr_ = nullptr;  // swscale's output: rows and end padded as libavutil pads them
  SwsContext* sws_ = nullptr;
  int stream_ = -1;
  double time_base_ = 0.0;
  std::int64_t start_ = 0;
  bool flushing_ = false;
};

bool VideoReader::Decoder::next(cv::Mat& bgr, double& t_s, bool& damaged) {
  av_log_set_callback(count_ffmpeg_log);
  const std::int64_t errors_before = g_ffmpeg_errors.load();
  int flagged = 0;
  for (;;) {
    const int r = avcodec_receive_frame(ctx_, frame_);
    if (r == 0) break;
    if (r == AVERROR_EOF) return false;
    if (r != AVERROR(EAGAIN)) {
      ++flagged;  // a frame the decoder could not make: the next one follows damage
      if (flushing_) return false;
      continue;
    }
    if (flushing_) return false;
    const int got = av_read_frame(fmt_, packet_);
    if (got < 0) {
      flushing_ = true;
      avcodec_send_packet(ctx_, nullptr);
      continue;
    }
    if (packet_->stream_index == stream_ && avcodec_send_packet(ctx_, packet_) < 0)
      ++flagged;  // a packet that does not decode: its frame is lost
    av_packet_unref(packet_);
  }
  damaged = flagged > 0 || g_ffmpeg_errors.load() != errors_before || frame_->decode_error_flags != 0 ||
            (frame_->flags & AV_FRAME_FLAG_CORRUPT) != 0;
  const std::int64_t pts = frame_->best_effort_timestamp;
  t_s = pts == AV_NOPTS_VALUE ? std::nan("") : static_cast<double>(pts - start_) * time_base_;
  to_bgr(bgr);
  av_frame_unref(frame_);
  return true;
}

void VideoReader::Decoder::to_bgr(cv::Mat& bgr) {
  // As OpenCV 4.6: the whole coded picture converted with bicubic chroma, then the
  // displayed width x height kept.
  const int cw = std::max(ctx_->coded_width, frame_->width), ch = std::max(ctx_->coded_height, frame_->height);
  sws_ = sws_getCachedContext(sws_, cw, ch, static_cast<AVPixelFormat>(frame_->format), cw, ch, AV_PIX_FMT_BGR24,
                              SWS_BICUBIC, nullptr, nullptr, nullptr);
  if (sws_ == nullptr)
    throw InputError(fmt::format("{}: frame pixel format {} cannot be converted", path_, frame_->format));
  // swscale's vector code writes 6-24 bytes past the end of a BGR24 row whose width mod 16
  // is 8-14 px (a 266 px wide clip: 18 bytes, which corrupted the heap). Its output is
  // therefore a frame of libavutil's own, rows aligned to 32 bytes and the buffer padded,
  // as OpenCV allocates it.
  if (bgr_->width != cw || bgr_->height != ch) {
    av_frame_unref(bgr_);
    bgr_->format = AV_PIX_FMT_BGR24;
    bgr_->width = cw;
    bgr_->height = ch;
    if (av_frame_get_buffer(bgr_, 32) < 0)
      throw InternalError(fmt::format("{}: cannot allocate a {}x{} frame", path_, cw, ch));
  }
  sws_scale(sws_, frame_->data, frame_->linesize, 0, ch, bgr_->data, bgr_->linesize);
  const cv::Mat full(ch, cw, CV_8UC3, bgr_->data[0], static_cast<std::size_t>(bgr_->linesize[0]));
  bgr = full(cv::Rect(0, 0, frame_->width, frame_->height)).clone();
}

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

VideoReader::VideoReader(const std::filesystem::path& path, double fps_override) : path_(path.string()) {
  fps_override_ = fps_override;
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
  // OpenCV turns frames by the stream's display matrix; so does read().
  if (cap_->get(cv::CAP_PROP_ORIENTATION_AUTO) != 0) {
    const int angle = static_cast<int>(std::lround(cap_->get(cv::CAP_PROP_ORIENTATION_META)));
    rotate_ = angle == 90 ? cv::ROTATE_90_CLOCKWISE : angle == 180 ? cv::ROTATE_180
              : angle == 270 ? cv::ROTATE_90_COUNTERCLOCKWISE : -1;
  }
  cap_.reset();  // its decoder threads are not needed: frames come from our own decoder
  decoder_ = std::make_unique<Decoder>(path_);
  if (fps_override > 0) {
    info_.fps = fps_override;  // frames timed index / fps; the container's clocks unused
    return;
  }
  // An MP4/MOV states its clock three times: the time stamps (stts, what FFmpeg reports
  // per frame), the track's duration (mdhd) and the stream's rate. A muxer that wrote
  // stamps which stall or wrap gives dt many times off; they must agree within 10 %.
  if (const auto c = read_mp4_clock(path_)) {
    const double n = static_cast<double>(c->samples), ts = static_cast<double>(c->timescale);
    const double stamped = c->stts_sum > 0 ? n * ts / static_cast<double>(c->stts_sum) : HUGE_VAL;
    const double lasting = c->duration > 0 ? n * ts / static_cast<double>(c->duration) : info_.fps;
    auto agree = [](double a, double b) { return std::abs(a - b) <= 0.1 * std::min(a, b); };
    if (c->zero_deltas > 0 || !agree(stamped, lasting) || !agree(stamped, info_.fps) || !agree(lasting, info_.fps))
      throw InputError(fmt::format(
          "{}: the container's clocks disagree: its time stamps give {} ({} frames in {:.6g} s{}), its duration "
          "{:.6g} fps, its stream {:.6g} fps; expected one frame rate (within 10 %): give --fps with the camera's "
          "frame rate (frames are then timed index / fps)",
          path_, c->stts_sum > 0 ? fmt::format("{:.6g} fps", stamped) : std::string("no rate"), c->samples,
          static_cast<double>(c->stts_sum) / ts,
          c->zero_deltas > 0 ? fmt::format(", {} of them at the time of the one before", c->zero_deltas) : "",
          lasting, info_.fps));
  }
}

VideoReader::~VideoReader() = default;

bool VideoReader::read(cv::Mat& gray, double& t_s) {
  cv::Mat frame;
  double stamp = 0.0;
  bool damaged = false;
  if (!decoder_->next(frame, stamp, damaged)) {
    if (info_.frame_count > 0 && next_ < info_.frame_count)
      throw InputError(fmt::format("{}: frame {}: cannot decode; the container declares {} "
                                   "frames (truncated or corrupt file?)",
                                   path_, next_, info_.frame_count));
    return false;
  }
  if (rotate_ >= 0) cv::rotate(frame, frame, rotate_);
  if (frame.size() != cv::Size(info_.width, info_.height))
    throw InputError(fmt::format("{}: frame {}: size {}x{} differs from the first frame's {}x{}",
                                 path_, next_, frame.cols, frame.rows, info_.width,
                                 info_.height));
  // The presentation time of the frame, from the stream's start. A frame without one,
  // or with one that does not move forward, follows the previous one by 1/fps.
  t_s = fps_override_ > 0 ? static_cast<double>(next_) / fps_override_ : stamp;
  if (!std::isfinite(t_s) || t_s < 0) t_s = static_cast<double>(next_) / info_.fps;
  if (next_ > 0 && !(t_s > last_t_s_)) t_s = last_t_s_ + 1.0 / info_.fps;
  last_t_s_ = t_s;
  gray = frame.depth() == CV_8U ? to_gray(frame, grey_mode_) : cv::Mat();
  if (gray.empty())
    throw InputError(fmt::format("{}: frame {}: unsupported sample depth; expected 8-bit video",
                                 path_, next_));
  last_damaged_ = damaged;
  damaged_ += last_damaged_;
  ++next_;
  return true;
}

namespace {

/// The encoder's bytes must not depend on the machine. FFmpeg's H.264 (x264) and MPEG-4
/// encoders choose their number of threads from the CPUs the opening thread may run on,
/// and the stream they write depends on that number; OpenCV 4.6 passes no option that
/// sets it. While the writer opens, the calling thread may run on one CPU only (the
/// first it was allowed), so every machine encodes with one thread and writes the same
/// bytes; the encoder's threads keep that CPU, the caller gets its own set back.
class OneCpuWhileOpening {
 public:
  OneCpuWhileOpening() {
    CPU_ZERO(&saved_);
    if (sched_getaffinity(0, sizeof(saved_), &saved_) != 0) return;
    cpu_set_t one;
    CPU_ZERO(&one);
    for (int cpu = 0; cpu < CPU_SETSIZE; ++cpu)
      if (CPU_ISSET(cpu, &saved_)) {
        CPU_SET(cpu, &one);
        break;
      }
    restore_ = sched_setaffinity(0, sizeof(one), &one) == 0;
  }
  ~OneCpuWhileOpening() {
    if (restore_) sched_setaffinity(0, sizeof(saved_), &saved_);
  }
  OneCpuWhileOpening(const OneCpuWhileOpening&) = delete;
  OneCpuWhileOpening& operator=(const OneCpuWhileOpening&) = delete;

 private:
  cpu_set_t saved_;
  bool restore_ = false;
};

/// FFmpeg's H.264 encoder, as OpenCV 4.6 drives it, reads heap memory nothing wrote: the
/// same frames written at 144x108 px gave three different streams over 9 runs while other
/// threads allocated (decoded, they differed from frame 33 on), and one stream in 9 runs
/// with glibc filling what it hands out and takes back with a fixed byte
/// (MALLOC_PERTURB_). While any writer is open, that fill is on (mallopt M_PERTURB, the
/// same setting), so the bytes read are the same on every run. Blocks glibc maps
/// directly (from 128 KiB, larger once such blocks have been freed) come zeroed and
/// need no fill.
constexpr int kHeapFillByte = 0xa5;
std::mutex& heap_fill_mutex() {
  static std::mutex m;
  return m;
}
int& heap_fill_users() {
  static int n = 0;
  return n;
}
void define_heap_while_encoding(bool on) {
  const std::lock_guard lock(heap_fill_mutex());
  int& n = heap_fill_users();
  if (on ? n++ == 0 : --n == 0) mallopt(M_PERTURB, on ? kHeapFillByte : 0);
}

}  // namespace

VideoWriter::VideoWriter(const std::filesystem::path& path, double fps, cv::Size size,
                         const std::string& codec, const std::filesystem::path& name)
    : path_(path.string()), name_(name.empty() ? path.string() : name.string()), size_(size) {
  if (codec.size() != 4)
    throw ConfigError(fmt::format("video codec \"{}\": expected a four-character code such as "
                                  "mp4v, avc1 or MJPG",
                                  codec));
  if (!(fps > 0)) throw ConfigError(fmt::format("video fps = {}: must be > 0", fps));
  define_heap_while_encoding(true);
  heap_defined_ = true;
  writer_ = std::make_unique<cv::VideoWriter>();
  const int fourcc = cv::VideoWriter::fourcc(codec[0], codec[1], codec[2], codec[3]);
  bool ok = false;
  try {
    // OpenCV prints "FFMPEG: tag ... is not found" straight to stderr: our line says it.
    const detail::StderrSilencer quiet;
    const OneCpuWhileOpening same_bytes_everywhere;
    ok = writer_->open(path_, cv::CAP_FFMPEG, fourcc, fps, size, false);
  } catch (const cv::Exception& e) {
    ok = false;
  }
  if (!ok) {
    close();
    throw ConfigError(fmt::format("{}: cannot open a video writer for codec \"{}\" at {}x{} px (the "
                                  "codec may not hold frames of this size, or this OpenCV/FFmpeg build "
                                  "lacks it; try mp4v or avc1 for .mp4, MJPG for .avi)",
                                  name_, codec, size.width, size.height));
  }
}

VideoWriter::~VideoWriter() { close(); }

void VideoWriter::write(const cv::Mat& gray8) {
  if (gray8.type() != CV_8UC1 || gray8.size() != size_)
    throw InternalError(fmt::format("{}: VideoWriter::write expects {}x{} CV_8UC1 frames", path_,
                                    size_.width, size_.height));
  writer_->write(gray8);
}

void VideoWriter::close() {
  if (writer_) writer_->release();
  if (heap_defined_) define_heap_while_encoding(false);
  heap_defined_ = false;
}

}  // namespace shearzone::io
