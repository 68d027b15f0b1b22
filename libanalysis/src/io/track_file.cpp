// Tracked beads on disk (io/track_file.hpp).
#include "shearzone/io/track_file.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <fstream>
#include <iterator>
#include <limits>
#include <type_traits>
#include <utility>

#include <fmt/format.h>

#include "shearzone/core/conventions.hpp"
#include "shearzone/core/error.hpp"
#include "shearzone/core/version.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/io/hdf5.hpp"

namespace shearzone::io {
namespace {

std::string lower_extension(const std::filesystem::path& p) {
  std::string e = p.extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return e;
}

/// HDF5 rows go in chunks of this many beads (a 1080p frame of 35 px beads holds
/// about 1 700), compressed at gzip level 1 as the field files.
constexpr std::size_t kChunkRows = 4096;

const char* const kInt64Columns[] = {"track_id", "frame_a", "frame_b"};
const char* const kDoubleColumns[] = {"t_a_s", "dt_s", "x_px", "y_px", "u_px", "v_px", "fb_px"};
const char* const kFlagColumns[] = {"tracked", "linked"};

// The columns in the order of the names above (const or not, as `t` is).
template <class Rows>
auto int64_columns(Rows& t) {
  return std::array{&t.track_id, &t.frame_a, &t.frame_b};
}
template <class Rows>
auto double_columns(Rows& t) {
  return std::array{&t.t_a_s, &t.dt_s, &t.x_px, &t.y_px, &t.u_px, &t.v_px, &t.fb_px};
}
template <class Rows>
auto flag_columns(Rows& t) {
  return std::array{&t.tracked, &t.linked};
}

}  // namespace

bool is_track_file_path(const std::filesystem::path& path) {
  const std::string e = lower_extension(path);
  return e == ".h5" || e == ".csv";
}

TrackFileWriter::TrackFileWriter(const std::filesystem::path& path, const core::Metadata& header)
    : csv_(lower_extension(path) == ".csv") {
  if (csv_) {
    file_ = std::make_unique<std::ofstream>(path, std::ios::binary);
    if (!*file_) throw InputError(fmt::format("{}: cannot create", path.string()));
    core::Metadata m = header;
    for (auto& kv : core::convention_metadata()) m.push_back(std::move(kv));
    csv_writer_ = std::make_unique<CsvWriter>(
        *file_, m,
        std::vector<std::string>{"track_id", "frame_a", "frame_b", "t_a_s", "dt_s", "x_px", "y_px", "u_px", "v_px",
                                 "vx_px_per_s", "vy_px_per_s", "fb_px", "tracked", "linked"});
    return;
  }
  h5_ = std::make_unique<H5File>(H5File::create(path));
  for (const char* c : kInt64Columns)
    h5_->create_column(std::string("/beads/") + c, H5File::Type::kInt64, kChunkRows, 1);
  for (const char* c : kDoubleColumns)
    h5_->create_column(std::string("/beads/") + c, H5File::Type::kFloat64, kChunkRows, 1);
  for (const char* c : kFlagColumns)
    h5_->create_column(std::string("/beads/") + c, H5File::Type::kUInt8, kChunkRows, 1);
  std::string text, conv;
  for (const auto& [k, v] : header) text += k + ": " + v + "\n";
  for (const auto& [k, v] : core::convention_metadata()) conv += k + ": " + v + "\n";
  h5_->set_attribute("/", "options", text);
  h5_->set_attribute("/", "conventions", conv);
  h5_->set_attribute("/", "shearzone_version", kVersion);
}

TrackFileWriter::~TrackFileWriter() = default;

void TrackFileWriter::append(const core::TrackedBeads& t) {
  const std::size_t n = t.size();
  for (std::size_t k = 0; k < n; ++k) max_id_ = std::max(max_id_, t.track_id[k]);
  rows_ += static_cast<std::int64_t>(n);
  if (csv_) {
    auto num = [](double v) { return CsvWriter::format_number(v); };
    auto opt = [](double v) { return format_number_or_empty(v); };
    for (std::size_t k = 0; k < n; ++k)
      csv_writer_->row(std::vector<std::string>{
          std::to_string(t.track_id[k]), std::to_string(t.frame_a[k]), std::to_string(t.frame_b[k]),
          num(t.t_a_s[k]), num(t.dt_s[k]), num(t.x_px[k]), num(t.y_px[k]), opt(t.u_px[k]), opt(t.v_px[k]),
          opt(t.u_px[k] / t.dt_s[k]), opt(t.v_px[k] / t.dt_s[k]), opt(t.fb_px[k]), std::to_string(t.tracked[k]),
          std::to_string(t.linked[k])});
    return;
  }
  if (n == 0) return;
  for (std::size_t i = 0; i < std::size(kInt64Columns); ++i)
    h5_->append(std::string("/beads/") + kInt64Columns[i], int64_columns(t)[i]->data(), n);
  for (std::size_t i = 0; i < std::size(kDoubleColumns); ++i)
    h5_->append(std::string("/beads/") + kDoubleColumns[i], double_columns(t)[i]->data(), n);
  for (std::size_t i = 0; i < std::size(kFlagColumns); ++i)
    h5_->append(std::string("/beads/") + kFlagColumns[i], flag_columns(t)[i]->data(), n);
}

void TrackFileWriter::set_attribute(const std::string& name, std::int64_t value) {
  if (h5_) h5_->set_attribute("/", name, value);
}
void TrackFileWriter::set_attribute(const std::string& name, double value) {
  if (h5_) h5_->set_attribute("/", name, value);
}
void TrackFileWriter::set_attribute(const std::string& name, const std::string& value) {
  if (h5_) h5_->set_attribute("/", name, value);
}

void TrackFileWriter::close() {
  if (csv_) {
    file_->flush();
    if (!*file_) throw InputError("tracks: write failed (disk full?)");
    file_->close();
    return;
  }
  h5_->set_attribute("/", "beads", rows_);
  h5_->set_attribute("/", "tracks", max_id_ + 1);
  h5_->close();
}

namespace {

/// Every column of /beads, checked for equal lengths.
core::TrackedBeads read_beads(const H5File& h5, const std::filesystem::path& path) {
  core::TrackedBeads t;
  std::size_t n = std::numeric_limits<std::size_t>::max();
  auto check_length = [&](const char* name, std::size_t size) {
    if (n == std::numeric_limits<std::size_t>::max()) n = size;
    if (size != n)
      throw InputError(fmt::format("{}: dataset \"/beads/{}\" holds {} rows; \"/beads/track_id\" {}",
                                   path.string(), name, size, n));
  };
  auto read = [&](const char* name, auto* column) {
    auto a = h5.read<typename std::remove_pointer_t<decltype(column)>::value_type>(std::string("/beads/") + name);
    check_length(name, a.data.size());
    *column = std::move(a.data);
  };
  for (std::size_t i = 0; i < std::size(kInt64Columns); ++i) read(kInt64Columns[i], int64_columns(t)[i]);
  for (std::size_t i = 0; i < std::size(kDoubleColumns); ++i) read(kDoubleColumns[i], double_columns(t)[i]);
  for (std::size_t i = 0; i < std::size(kFlagColumns); ++i) read(kFlagColumns[i], flag_columns(t)[i]);
  return t;
}

/// A tracks file's pairs (rows of one frame_a, in the order written), each tracked
/// bead a vector at the midpoint of its displacement.
class TrackPairReader final : public PairReader {
 public:
  TrackPairReader(H5File h5, const std::filesystem::path& path)
      : h5_(std::move(h5)), path_(path), beads_(read_beads(h5_, path)) {
    const std::size_t n = beads_.size();
    for (std::size_t k = 0; k < n; ++k) {
      if (k > 0 && beads_.frame_a[k] == beads_.frame_a[k - 1]) {
        if (beads_.dt_s[k] != beads_.dt_s[k - 1] || beads_.t_a_s[k] != beads_.t_a_s[k - 1])
          throw InputError(fmt::format("{}: /beads row {}: t_a_s {}, dt_s {} differ from the row before in the same "
                                       "pair (frame_a {})",
                                       path.string(), k, format_number(beads_.t_a_s[k]),
                                       format_number(beads_.dt_s[k]), beads_.frame_a[k]));
        continue;
      }
      if (k > 0 && beads_.frame_a[k] < beads_.frame_a[k - 1])
        throw InputError(fmt::format("{}: /beads row {}: frame_a {} after {}: expected the pairs in time order",
                                     path.string(), k, beads_.frame_a[k], beads_.frame_a[k - 1]));
      starts_.push_back(k);
    }
    starts_.push_back(n);
  }
  std::size_t size() const override { return starts_.size() - 1; }
  void read_points(std::size_t k, core::PointVectors& p, double& t_a, double& dt) override {
    p.clear();
    const std::size_t begin = starts_[k], end = starts_[k + 1];
    for (std::size_t r = begin; r < end; ++r) {
      const double x = beads_.x_px[r], y = beads_.y_px[r], u = beads_.u_px[r], v = beads_.v_px[r];
      if (beads_.tracked[r] > 1)
        throw InputError(fmt::format("{}: /beads/tracked[{}] = {}: expected 0 or 1", path_.string(), r,
                                     static_cast<int>(beads_.tracked[r])));
      if (beads_.tracked[r] == 0) {
        p.push_back(x, y, 0.0, 0.0, core::VectorFlag::kInvalid);
        continue;
      }
      if (!(std::isfinite(x) && std::isfinite(y) && std::isfinite(u) && std::isfinite(v)))
        throw InputError(fmt::format("{}: /beads row {}: x_px {}, y_px {}, u_px {}, v_px {}: a tracked bead needs "
                                     "a finite centre and displacement",
                                     path_.string(), r, x, y, u, v));
      p.push_back(x + 0.5 * u, y + 0.5 * v, u, v, core::VectorFlag::kValid);
    }
    t_a = beads_.t_a_s[begin];
    dt = beads_.dt_s[begin];
  }
  double attribute(const std::string& name) const override { return h5_.root_number(name); }
  std::string text_attribute(const std::string& name) const override { return h5_.root_text(name); }
  bool beads() const override { return true; }

 private:
  H5File h5_;
  std::filesystem::path path_;
  core::TrackedBeads beads_;
  std::vector<std::size_t> starts_;  // first row of each pair, then the row count
};

}  // namespace

core::TrackedBeads read_track_file(const std::filesystem::path& path, std::string* options) {
  const H5File h5 = H5File::open_read(path);
  core::TrackedBeads t = read_beads(h5, path);
  if (options) *options = h5.has_attribute("/", "options") ? h5.attribute_string("/", "options") : std::string();
  return t;
}

std::unique_ptr<PairReader> open_pair_file(const std::filesystem::path& path, double csv_dt_s) {
  if (!is_field_csv(path)) {
    H5File h5 = H5File::open_read(path);
    if (h5.exists("/beads/track_id")) return std::make_unique<TrackPairReader>(std::move(h5), path);
    return open_field_file(std::move(h5), path);  // opened (and its metadata walked) once
  }
  return open_field_file(path, csv_dt_s);
}

}  // namespace shearzone::io
