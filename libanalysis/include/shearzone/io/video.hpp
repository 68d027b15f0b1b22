// shearzone/io/video.hpp: reading and writing video (FFmpeg, through OpenCV for writing).
//
// VideoReader gives grey frames with their presentation times from the container, so
// that velocity = displacement / (t_b - t_a) holds even for variable frame rates; a
// frame without a time, or with one that does not move forward, is the previous one
// plus 1/fps. The container's rate, frame count and codec are OpenCV's; the frames are
// decoded by libavcodec on one thread (OpenCV decodes on one thread per CPU, and a
// damaged stream then gives other frames on every run), converted to BGR as OpenCV
// converts them, so an intact file reads as OpenCV reads it. A file that will not open, or whose frames stop decoding
// before the frame count the container declares, is an InputError naming the file
// and the frame index.
//
// VideoWriter writes 8-bit grey frames as MP4 (codec "mp4v" by default, or "avc1"
// where the FFmpeg build has an H.264 encoder) or AVI ("MJPG"). Write to
// AtomicOutput::temp_path(), which keeps the extension, then commit.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

#include <opencv2/core.hpp>

#include "shearzone/io/image.hpp"

namespace cv {
class VideoCapture;
class VideoWriter;
}  // namespace cv

namespace shearzone::io {

struct VideoInfo {
  double fps = 0.0;              ///< frames per second, as the container declares it
  std::int64_t frame_count = 0;  ///< declared number of frames (may be approximate for some codecs)
  int width = 0;                 ///< px
  int height = 0;                ///< px
  std::string codec;             ///< FourCC as text, e.g. "mp4v", "avc1", "MJPG"
};

class VideoReader {
 public:
  /// `fps_override` > 0: frames are timed index / fps_override (the container's time
  /// stamps and rate unused). Otherwise an MP4/MOV whose time stamps, track duration and
  /// stream rate disagree by more than 10 % (stamps that stall or wrap) is an InputError.
  explicit VideoReader(const std::filesystem::path& path, double fps_override = 0.0);
  ~VideoReader();
  VideoReader(const VideoReader&) = delete;
  VideoReader& operator=(const VideoReader&) = delete;

  const VideoInfo& info() const { return info_; }
  const std::string& path() const { return path_; }

  /// Reads the next frame as grey CV_8U; `t_s` receives its timestamp in s.
  /// Returns false at the declared end of the video. Throws InputError if a frame
  /// before the declared end cannot be decoded (a truncated or corrupt file).
  bool read(cv::Mat& gray, double& t_s);
  /// Colour-to-grey conversion of read() (luma by default).
  void set_grey_mode(GreyMode mode) { grey_mode_ = mode; }
  /// Index of the frame the next read() returns.
  std::int64_t next_index() const { return next_; }
  /// True if the decoder reported an error, concealed, or lost a frame while the last
  /// read() decoded its frame (the frame holds concealed, invented pixels, or follows a
  /// lost one); and how many such frames so far. The same on every run.
  bool last_frame_damaged() const { return last_damaged_; }
  std::int64_t damaged_frames() const { return damaged_; }
  /// True when frames are timed index / fps (the container's stamps unused).
  bool timed_by_index() const { return fps_override_ > 0; }

 private:
  std::string path_;
  class Decoder;
  std::unique_ptr<cv::VideoCapture> cap_;  ///< open while the container's properties are read
  std::unique_ptr<Decoder> decoder_;
  VideoInfo info_;
  int rotate_ = -1;  ///< cv::RotateFlags from the display matrix, or -1
  std::int64_t next_ = 0;
  double last_t_s_ = 0.0;  ///< the previous frame's time
  double fps_override_ = 0.0;  ///< > 0: frames timed index / fps_override_
  GreyMode grey_mode_ = GreyMode::kLuma;
  bool last_damaged_ = false;
  std::int64_t damaged_ = 0;
};

class VideoWriter {
 public:
  /// `codec`: "mp4v", "avc1" or "MJPG" (a FourCC). `path` decides the container by
  /// its extension (.mp4, .avi). Throws ConfigError if the combination cannot be
  /// opened by this build of OpenCV/FFmpeg.
  /// `name`: the file messages name (the final output, when `path` is its temporary).
  VideoWriter(const std::filesystem::path& path, double fps, cv::Size size, const std::string& codec = "mp4v",
              const std::filesystem::path& name = {});
  ~VideoWriter();
  VideoWriter(const VideoWriter&) = delete;
  VideoWriter& operator=(const VideoWriter&) = delete;

  /// Appends a grey CV_8U frame of the size given at construction.
  void write(const cv::Mat& gray8);
  void close();

 private:
  std::string path_;
  std::string name_;  ///< the file messages name
  cv::Size size_;
  std::unique_ptr<cv::VideoWriter> writer_;
  bool heap_defined_ = false;  ///< counted among the writers that keep the heap fill on (video.cpp)
};

/// True for the video extensions VideoReader is meant for (.mp4, .avi, .mov, .mkv).
bool is_video_extension(const std::filesystem::path& path);

/// True if the file's first bytes are those of a video container (ISO media /
/// MP4 / MOV "ftyp", AVI "RIFF....AVI ", Matroska/WebM), whatever its name.
bool looks_like_video(const std::filesystem::path& path);

}  // namespace shearzone::io
