// shearzone/io/frames.hpp: one interface over a video file and an image sequence.
//
// Frames come out one at a time, grey, with their index in the source and a time:
// the container's timestamp for a video, index / fps for an image sequence. The
// whole clip is never held in memory.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "shearzone/io/image.hpp"

namespace shearzone::io {

struct Frame {
  cv::Mat gray;             ///< CV_8U or CV_16U, one channel
  std::int64_t index = 0;   ///< position in the source, from 0
  double t_s = 0.0;         ///< time, s
  std::string label;        ///< "clip.mp4#12" or the image's path, for messages
  bool damaged = false;     ///< the decoder reported an error for this frame (video)
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  /// The next frame; false at the end. Throws InputError on a frame that cannot be
  /// read or whose size differs from the first one's.
  virtual bool next(Frame& frame) = 0;
  /// Frames per second (declared by the container, or given for a sequence).
  virtual double fps() const = 0;
  /// Number of frames if known in advance (0 if not).
  virtual std::int64_t size_hint() const = 0;
  /// What the frames come from, for output metadata.
  virtual std::string description() const = 0;
};

/// Opens `inputs`: one video file (.mp4, .avi, .mov, .mkv); one glob pattern
/// ("frames/*.png", expanded and sorted by name); or a list of image files, in the
/// order given. `fps` sets the time base of image sequences (t = index / fps);
/// `video_fps` > 0 times a video's frames index / video_fps instead of by the
/// container's time stamps (VideoReader).
/// Throws InputError for a missing file, a pattern that matches nothing, or an
/// unsupported extension; ConfigError for an empty input list.
std::unique_ptr<FrameSource> open_frames(const std::vector<std::string>& inputs, double fps,
                                         GreyMode grey = GreyMode::kLuma, double video_fps = 0.0);

/// Frames held in memory (the Python module's arrays), in order: CV_8U, CV_16U or CV_32F
/// (0..1), one channel, all of one size and type (InputError naming `name`#k otherwise).
/// Frame k is timed k / fps and labelled "`name`#k"; the Mats are shared, not copied.
std::unique_ptr<FrameSource> frames_from_memory(std::vector<cv::Mat> frames, double fps, std::string name);

/// Expands a glob pattern; the matches, sorted. Empty if nothing matches.
std::vector<std::string> expand_glob(const std::string& pattern);

}  // namespace shearzone::io
