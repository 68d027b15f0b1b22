#include "shearzone/io/frames.hpp"

#include <glob.h>

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/io/image.hpp"
#include "shearzone/io/video.hpp"

namespace shearzone::io {
namespace {

class VideoSource : public FrameSource {
 public:
  VideoSource(const std::string& path, GreyMode grey, double fps) : reader_(path, fps), path_(path) {
    reader_.set_grey_mode(grey);
  }
  bool next(Frame& f) override {
    const std::int64_t k = reader_.next_index();
    if (!reader_.read(f.gray, f.t_s)) return false;
    f.index = k;
    f.label = fmt::format("{}#{}", path_, k);
    f.damaged = reader_.last_frame_damaged();
    return true;
  }
  double fps() const override { return reader_.info().fps; }
  std::int64_t size_hint() const override { return reader_.info().frame_count; }
  std::string description() const override {
    return fmt::format("{} ({}x{}, {} fps{}, {} frames, codec {})", path_, reader_.info().width,
                       reader_.info().height, reader_.info().fps,
                       reader_.timed_by_index() ? " (--fps: frames timed index / fps, the container's time stamps "
                                                  "unused)"
                                                : "",
                       reader_.info().frame_count, reader_.info().codec);
  }

 private:
  VideoReader reader_;
  std::string path_;
};

class ImageSequenceSource : public FrameSource {
 public:
  ImageSequenceSource(std::vector<std::string> paths, double fps, GreyMode grey)
      : paths_(std::move(paths)), fps_(fps), grey_(grey) {}
  bool next(Frame& f) override {
    if (next_ >= paths_.size()) return false;
    const std::string& p = paths_[next_];
    f.gray = read_image_gray(p, nullptr, grey_);
    if (size_.width == 0) size_ = f.gray.size();
    if (f.gray.size() != size_)
      throw InputError(fmt::format("{}: image is {}x{}; expected {}x{} like the first frame ({})",
                                   p, f.gray.cols, f.gray.rows, size_.width, size_.height,
                                   paths_.front()));
    f.index = static_cast<std::int64_t>(next_);
    f.t_s = static_cast<double>(next_) / fps_;
    f.label = p;
    ++next_;
    return true;
  }
  double fps() const override { return fps_; }
  std::int64_t size_hint() const override { return static_cast<std::int64_t>(paths_.size()); }
  std::string description() const override {
    return fmt::format("{} images ({} ... {}), {} fps", paths_.size(), paths_.front(),
                       paths_.back(), fps_);
  }

 private:
  std::vector<std::string> paths_;
  double fps_;
  GreyMode grey_;
  std::size_t next_ = 0;
  cv::Size size_{0, 0};
};

const char* depth_name(const cv::Mat& m) {
  return m.depth() == CV_8U ? "uint8" : m.depth() == CV_16U ? "uint16" : m.depth() == CV_32F ? "float32" : "another type";
}

class MemorySource : public FrameSource {
 public:
  MemorySource(std::vector<cv::Mat> frames, double fps, std::string name)
      : frames_(std::move(frames)), fps_(fps), name_(std::move(name)) {}
  bool next(Frame& f) override {
    if (next_ >= frames_.size()) return false;
    f.gray = frames_[next_];
    f.index = static_cast<std::int64_t>(next_);
    f.t_s = static_cast<double>(next_) / fps_;
    f.label = fmt::format("{}#{}", name_, next_);
    f.damaged = false;
    ++next_;
    return true;
  }
  double fps() const override { return fps_; }
  std::int64_t size_hint() const override { return static_cast<std::int64_t>(frames_.size()); }
  std::string description() const override {
    const cv::Mat& m = frames_.front();
    return fmt::format("{} {} frames of {}x{} px in memory, {} fps", frames_.size(),
                       depth_name(m), m.cols, m.rows, fps_);
  }

 private:
  std::vector<cv::Mat> frames_;
  double fps_;
  std::string name_;
  std::size_t next_ = 0;
};

bool has_glob_chars(const std::string& s) { return s.find_first_of("*?[") != std::string::npos; }

}  // namespace

std::unique_ptr<FrameSource> frames_from_memory(std::vector<cv::Mat> frames, double fps, std::string name) {
  if (frames.size() < 2) throw InputError(fmt::format("{}: {} frame{}: a pair needs two", name, frames.size(), frames.size() == 1 ? "" : "s"));
  if (!(fps > 0) || !std::isfinite(fps)) throw ConfigError(fmt::format("fps = {}: must be > 0 for frames in memory", fps));
  for (std::size_t k = 0; k < frames.size(); ++k) {
    const cv::Mat& m = frames[k];
    if (m.empty()) throw InputError(fmt::format("{}#{}: an empty array (0 px); expected a 2-D grey image", name, k));
    if (m.channels() != 1 || (m.depth() != CV_8U && m.depth() != CV_16U && m.depth() != CV_32F))
      throw InputError(fmt::format("{}#{}: expected a 2-D array of uint8, uint16 or float32 grey levels", name, k));
    if (m.size() != frames[0].size() || m.type() != frames[0].type())
      throw InputError(fmt::format("{}#{}: {}x{} px of {}; frame 0 is {}x{} px of {}: frames must match", name, k,
                                   m.cols, m.rows, depth_name(m), frames[0].cols, frames[0].rows,
                                   depth_name(frames[0])));
    // (checkRange's upper bound is exclusive and compared in float: the float after 1)
    if (m.depth() == CV_32F && !cv::checkRange(m, true, nullptr, 0.0, std::nextafter(1.0F, 2.0F)))
      throw InputError(fmt::format("{}#{}: float grey levels outside 0..1 (or not finite); expected 0..1", name, k));
  }
  return std::make_unique<MemorySource>(std::move(frames), fps, std::move(name));
}

std::vector<std::string> expand_glob(const std::string& pattern) {
  glob_t g{};
  std::vector<std::string> out;
  if (::glob(pattern.c_str(), 0, nullptr, &g) == 0)
    for (std::size_t i = 0; i < g.gl_pathc; ++i) out.emplace_back(g.gl_pathv[i]);
  ::globfree(&g);
  std::sort(out.begin(), out.end());
  return out;
}

std::unique_ptr<FrameSource> open_frames(const std::vector<std::string>& inputs, double fps,
                                         GreyMode grey, double video_fps) {
  if (inputs.empty()) throw ConfigError("no input frames given");
  if (inputs.size() == 1 && (is_video_extension(inputs[0]) ||
                             (!is_readable_image_extension(inputs[0]) && looks_like_video(inputs[0]))))
    return std::make_unique<VideoSource>(inputs[0], grey, video_fps);
  if (!(fps > 0) || !std::isfinite(fps))
    throw ConfigError(fmt::format("fps = {}: must be > 0 for an image sequence", fps));
  std::vector<std::string> paths;
  for (const auto& in : inputs) {
    if (has_glob_chars(in) && !std::filesystem::exists(in)) {
      auto m = expand_glob(in);
      if (m.empty()) throw InputError(fmt::format("{}: pattern matches no file", in));
      paths.insert(paths.end(), m.begin(), m.end());
    } else {
      if (is_video_extension(in))
        throw ConfigError(fmt::format("{}: a video must be the only input", in));
      paths.push_back(in);
    }
  }
  for (const auto& p : paths) {
    if (!std::filesystem::exists(p)) throw InputError(fmt::format("{}: no such file", p));
    // Known image extensions are read as images (the decoder names a bad file); any
    // other name is taken by content.
    if (!is_readable_image_extension(p) && !looks_like_image(p))
      throw InputError(fmt::format("{}: not an image or a video: the name and the first bytes "
                                   "match none of the formats read (images: {}; videos: .mp4, "
                                   ".avi, .mov, .mkv)",
                                   p, decoded_image_formats()));
  }
  return std::make_unique<ImageSequenceSource>(std::move(paths), fps, grey);
}

}  // namespace shearzone::io
