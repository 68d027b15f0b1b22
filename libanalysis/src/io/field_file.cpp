#include "shearzone/io/field_file.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/core/unset.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/io/file.hpp"
#include "shearzone/io/hdf5.hpp"

namespace shearzone::io {

namespace {

class H5Reader final : public FieldReader {
 public:
  H5Reader(H5File h5, const std::filesystem::path& path) : h5_(std::move(h5)), path_(path) {
    for (const char* d : {"/grid/x_px", "/grid/y_px", "/pairs/u_px", "/pairs/v_px", "/pairs/flag",
                          "/pairs/t_a_s", "/pairs/dt_s"})
      if (!h5_.exists(d))
        throw InputError(fmt::format("{}: dataset \"{}\" missing: not a field file of `shearzone piv`",
                                     path.string(), d));
    // Declared sizes against the file and the memory budget before anything is read.
    for (const char* d : {"/pairs/u_px", "/pairs/v_px", "/pairs/flag"}) h5_.check_declared(d);
    x_ = h5_.read<double>("/grid/x_px").data;
    y_ = h5_.read<double>("/grid/y_px").data;
    t_a_ = h5_.read<double>("/pairs/t_a_s").data;
    dt_ = h5_.read<double>("/pairs/dt_s").data;
    const auto d = h5_.dims("/pairs/u_px");
    if (d.size() != 3 || d[1] != y_.size() || d[2] != x_.size() || t_a_.size() != d[0] || dt_.size() != d[0])
      throw InputError(fmt::format("{}: /pairs/u_px has the wrong shape for the grid ({} x {})", path.string(),
                                   y_.size(), x_.size()));
    n_ = d[0];
  }
  std::size_t size() const override { return n_; }
  void read(std::size_t k, core::VectorField& f, double& t_a, double& dt) override {
    if (f.x_px.empty()) {
      f.x_px = x_;
      f.y_px = y_;
      f.resize_to_grid();
      flags_.resize(f.size());
    }
    h5_.read_record("/pairs/u_px", k, f.u_px.data());
    h5_.read_record("/pairs/v_px", k, f.v_px.data());
    h5_.read_record("/pairs/flag", k, flags_.data());
    for (std::size_t i = 0; i < flags_.size(); ++i) {
      if (flags_[i] > 3)
        throw InputError(fmt::format("{}: /pairs/flag[{}] = {}: expected 0..3", path_.string(), k,
                                     static_cast<int>(flags_[i])));
      f.flag[i] = static_cast<core::VectorFlag>(flags_[i]);
      // A measured vector must be a number: NaN would turn its whole bin into NaN.
      const bool measured = f.flag[i] == core::VectorFlag::kValid || f.flag[i] == core::VectorFlag::kReplaced;
      if (measured && !(std::isfinite(f.u_px[i]) && std::isfinite(f.v_px[i])))
        throw InputError(fmt::format("{}: /pairs/{}[{}][{}][{}] = {}: expected a finite displacement "
                                     "(flag {})",
                                     path_.string(), std::isfinite(f.u_px[i]) ? "v_px" : "u_px", k, i / f.nx(),
                                     i % f.nx(), std::isfinite(f.u_px[i]) ? f.v_px[i] : f.u_px[i],
                                     core::flag_name(f.flag[i])));
    }
    t_a = t_a_[k];
    dt = dt_[k];
  }
  double attribute(const std::string& name) const override { return h5_.root_number(name); }
  std::string text_attribute(const std::string& name) const override { return h5_.root_text(name); }

 private:
  H5File h5_;
  std::filesystem::path path_;
  std::vector<double> x_, y_, t_a_, dt_;
  std::vector<std::uint8_t> flags_;
  std::size_t n_ = 0;
};

class CsvReader final : public FieldReader {
 public:
  CsvReader(const std::filesystem::path& path, double dt) : dt_(dt) {
    const CsvTable t = read_csv(path);
    if (t.num_rows() == 0) throw InputError(fmt::format("{}: no vectors", path.string()));
    const auto x = t.numeric_column("x_px"), y = t.numeric_column("y_px");
    const auto u = t.numeric_column("u_px"), v = t.numeric_column("v_px");
    const auto fl = t.text_column("flag");
    std::vector<double> xs = x, ys = y;
    std::sort(xs.begin(), xs.end());
    xs.erase(std::unique(xs.begin(), xs.end()), xs.end());
    std::sort(ys.begin(), ys.end());
    ys.erase(std::unique(ys.begin(), ys.end()), ys.end());
    if (xs.size() * ys.size() != t.num_rows())
      throw InputError(fmt::format("{}: {} rows do not fill a regular grid of {} x {} points", path.string(),
                                   t.num_rows(), xs.size(), ys.size()));
    f_.x_px = xs;
    f_.y_px = ys;
    f_.resize_to_grid();
    for (std::size_t r = 0; r < t.num_rows(); ++r) {
      const auto j = static_cast<std::size_t>(std::lower_bound(xs.begin(), xs.end(), x[r]) - xs.begin());
      const auto i = static_cast<std::size_t>(std::lower_bound(ys.begin(), ys.end(), y[r]) - ys.begin());
      const std::size_t k = f_.index(i, j);
      f_.u_px[k] = static_cast<float>(u[r]);
      f_.v_px[k] = static_cast<float>(v[r]);
      bool ok = false;
      for (auto flag : {core::VectorFlag::kValid, core::VectorFlag::kReplaced, core::VectorFlag::kMasked,
                        core::VectorFlag::kInvalid})
        if (fl[r] == core::flag_name(flag)) {
          f_.flag[k] = flag;
          ok = true;
        }
      if (!ok)
        throw InputError(fmt::format("{}:{}: column \"flag\": \"{}\": expected valid, replaced, "
                                     "masked or invalid",
                                     path.string(), t.row_lines[r], fl[r]));
    }
    for (const auto& kv : t.metadata) meta_[kv.first] = kv.second;
  }
  std::size_t size() const override { return 1; }
  void read(std::size_t, core::VectorField& f, double& t_a, double& dt) override {
    f = f_;
    t_a = 0;
    dt = dt_;
  }
  double attribute(const std::string& name) const override {
    auto it = meta_.find(name);
    double v = 0;
    return it != meta_.end() && parse_number(it->second, false, v) ? v : core::kUnset;
  }
  std::string text_attribute(const std::string& name) const override {
    auto it = meta_.find(name);
    return it == meta_.end() ? std::string() : it->second;
  }

 private:
  core::VectorField f_;
  double dt_;
  std::map<std::string, std::string> meta_;
};

}  // namespace

bool is_field_csv(const std::filesystem::path& p) { return has_extension(p, ".csv"); }

void write_field_csv(std::ostream& os, const core::Metadata& meta, const core::VectorField& f) {
  CsvWriter w(os, meta, {"x_px", "y_px", "u_px", "v_px", "flag", "peak", "peak_ratio"});
  const auto fl = [](float v) { return CsvWriter::format_float(v); };
  for (std::size_t i = 0; i < f.ny(); ++i)
    for (std::size_t j = 0; j < f.nx(); ++j) {
      const std::size_t k = f.index(i, j);
      w.row(std::vector<std::string>{format_number(f.x_px[j]), format_number(f.y_px[i]), fl(f.u_px[k]),
                                     fl(f.v_px[k]), core::flag_name(f.flag[k]), fl(f.peak[k]),
                                     fl(f.peak_ratio[k])});
    }
}

FieldFileWriter::FieldFileWriter(std::filesystem::path path) : path_(std::move(path)) {}
FieldFileWriter::~FieldFileWriter() = default;
FieldFileWriter::FieldFileWriter(FieldFileWriter&&) noexcept = default;
FieldFileWriter& FieldFileWriter::operator=(FieldFileWriter&&) noexcept = default;

void FieldFileWriter::append(const core::VectorField& f, std::int64_t frame_a, std::int64_t frame_b, double t_a_s,
                             double dt_s) {
  if (!h5_) {
    h5_ = std::make_unique<H5File>(H5File::create(path_));
    h5_->write("/grid/x_px", {f.nx()}, f.x_px);
    h5_->write("/grid/y_px", {f.ny()}, f.y_px);
    using T = H5File::Type;
    for (const char* name : {"/pairs/u_px", "/pairs/v_px", "/pairs/peak", "/pairs/peak_ratio"})
      h5_->create_appendable(name, {f.ny(), f.nx()}, T::kFloat32, 1);
    h5_->create_appendable("/pairs/flag", {f.ny(), f.nx()}, T::kUInt8, 1);
    h5_->create_appendable("/pairs/frame_a", {}, T::kInt64);
    h5_->create_appendable("/pairs/frame_b", {}, T::kInt64);
    h5_->create_appendable("/pairs/t_a_s", {}, T::kFloat64);
    h5_->create_appendable("/pairs/dt_s", {}, T::kFloat64);
    h5_->set_attribute("/pairs/flag", "mapping", core::flag_mapping());
  }
  h5_->append("/pairs/u_px", f.u_px.data());
  h5_->append("/pairs/v_px", f.v_px.data());
  h5_->append("/pairs/peak", f.peak.data());
  h5_->append("/pairs/peak_ratio", f.peak_ratio.data());
  std::vector<std::uint8_t> flags(f.size());
  for (std::size_t k = 0; k < f.size(); ++k) flags[k] = static_cast<std::uint8_t>(f.flag[k]);
  h5_->append("/pairs/flag", flags.data());
  h5_->append("/pairs/frame_a", &frame_a);
  h5_->append("/pairs/frame_b", &frame_b);
  h5_->append("/pairs/t_a_s", &t_a_s);
  h5_->append("/pairs/dt_s", &dt_s);
}

void FieldFileWriter::set_attribute(const std::string& name, double value) { h5_->set_attribute("/", name, value); }
void FieldFileWriter::set_attribute(const std::string& name, std::int64_t value) {
  h5_->set_attribute("/", name, value);
}
void FieldFileWriter::set_attribute(const std::string& name, const std::string& value) {
  h5_->set_attribute("/", name, value);
}
void FieldFileWriter::close() {
  if (h5_) h5_->close();
}

void FieldReader::read_points(std::size_t k, core::PointVectors& points, double& t_a_s, double& dt_s) {
  read(k, grid_, t_a_s, dt_s);
  core::to_points(grid_, points);
}

std::unique_ptr<FieldReader> open_field_file(const std::filesystem::path& path, double csv_dt_s) {
  if (is_field_csv(path)) return std::make_unique<CsvReader>(path, csv_dt_s);
  return std::make_unique<H5Reader>(H5File::open_read(path), path);
}

std::unique_ptr<FieldReader> open_field_file(H5File h5, const std::filesystem::path& path) {
  return std::make_unique<H5Reader>(std::move(h5), path);
}

}  // namespace shearzone::io
