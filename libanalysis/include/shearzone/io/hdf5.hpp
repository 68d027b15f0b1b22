// shearzone/io/hdf5.hpp: small HDF5 helpers for arrays plus attributes.
//
// Used by PIV field files and simulator snapshots. Datasets are dense, row-major
// (C order) arrays of float32, float64, int64, int32 or uint8; intermediate groups
// are created as needed ("/pairs/u_px" creates "/pairs"). Attributes are scalars
// (string, float64, int64) or float64 vectors, on the root ("/"), a group or a
// dataset. Reading converts to the requested element type (HDF5 does it).
//
// Errors: HDF5's own error-stack printing is switched off; every failure is an
// InputError naming the file and the object, e.g.
//     fields.h5: dataset "/pairs/u_px": not found
// For writing a file atomically, create it at io::AtomicOutput::temp_path() and
// commit after close().
//
// Thread-safety: Debian's HDF5 is not built thread-safe; use one H5File from one
// thread at a time and do not use two at once from different threads.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace shearzone::io {

template <class T>
struct H5Array {
  std::vector<std::size_t> dims;  ///< row-major extents
  std::vector<T> data;            ///< product(dims) elements
};

/// Memory a reader may allocate for one input: SHEARZONE_MEMORY_MB (MiB) when set,
/// else a quarter of the physical memory.
std::size_t memory_budget_bytes();

namespace detail {
/// Runs `work` in a forked child process and waits at most `seconds` for it. Throws
/// InputError naming `file` ("not a valid HDF5 file: HDF5 crashed <what> (signal 11)")
/// when the child dies by a signal, exits non-zero (a sanitizer's report, an exception)
/// or runs past the limit (it is killed). The child's stderr goes to /dev/null and its
/// crash handlers are the system's defaults, so nothing reaches the user but that one
/// line. Where fork fails (a process too large to duplicate under the kernel's
/// overcommit rule) `work` is not run and nothing is thrown. H5File::open_read walks a
/// file's metadata this way before opening it: HDF5 1.10 crashes on some corrupt files.
void run_in_child(const std::string& file, const std::string& what, double seconds,
                  const std::function<void()>& work);
}  // namespace detail

class H5File {
 public:
  /// Opens an existing file read-only, after checking its superblock and group heaps
  /// against its size and walking its metadata in a child process (detail::run_in_child):
  /// a corrupt file is an InputError, never a crash of this process.
  static H5File open_read(const std::filesystem::path& path);
  /// Creates (truncating) a file for writing.
  static H5File create(const std::filesystem::path& path);

  H5File(H5File&& other) noexcept;
  H5File& operator=(H5File&& other) noexcept;
  H5File(const H5File&) = delete;
  H5File& operator=(const H5File&) = delete;
  ~H5File();

  /// Flushes and closes; throws InputError if HDF5 reports a failure. The
  /// destructor closes silently.
  void close();
  const std::string& path() const { return path_; }

  /// True if a group or dataset exists at `object` ("/grid/x_px").
  bool exists(const std::string& object) const;

  void write(const std::string& dataset, const std::vector<std::size_t>& dims, const float* data);
  void write(const std::string& dataset, const std::vector<std::size_t>& dims, const double* data);
  void write(const std::string& dataset, const std::vector<std::size_t>& dims,
             const std::int64_t* data);
  void write(const std::string& dataset, const std::vector<std::size_t>& dims,
             const std::int32_t* data);
  void write(const std::string& dataset, const std::vector<std::size_t>& dims,
             const std::uint8_t* data);
  template <class T>
  void write(const std::string& dataset, const std::vector<std::size_t>& dims,
             const std::vector<T>& data) {
    check_size(dataset, dims, data.size());
    write(dataset, dims, data.data());
  }

  /// Extendible datasets for streaming: create with the shape of one record
  /// (`record_dims`, e.g. {ny, nx}), then append records one at a time; the dataset
  /// is [n, record_dims...], chunked by one record and gzip-compressed at `level`
  /// (0: none). Element types as for write().
  enum class Type { kFloat32, kFloat64, kInt64, kUInt8 };
  void create_appendable(const std::string& dataset, const std::vector<std::size_t>& record_dims,
                         Type type, int compression_level = 0);
  /// A 1-D table column [n] that grows by many records at a time (append(dataset,
  /// records, count)), chunked by `chunk_records` and gzip-compressed at `level`.
  void create_column(const std::string& dataset, Type type, std::size_t chunk_records, int compression_level);
  void append(const std::string& dataset, const float* record);
  void append(const std::string& dataset, const double* record);
  void append(const std::string& dataset, const std::int64_t* record);
  void append(const std::string& dataset, const std::uint8_t* record);
  /// Appends `count` records at once (a column's rows of one pair).
  void append(const std::string& dataset, const double* records, std::size_t count);
  void append(const std::string& dataset, const std::int64_t* records, std::size_t count);
  void append(const std::string& dataset, const std::uint8_t* records, std::size_t count);

  /// Dimensions of a dataset.
  std::vector<std::size_t> dims(const std::string& dataset) const;
  /// Reads record `index` of a dataset [n, record_dims...] into `out` (the product
  /// of record_dims elements): the streaming counterpart of append().
  void read_record(const std::string& dataset, std::size_t index, float* out) const;
  void read_record(const std::string& dataset, std::size_t index, double* out) const;
  void read_record(const std::string& dataset, std::size_t index, std::uint8_t* out) const;
  /// Checks what a dataset declares before anything is allocated for it: its size
  /// must fit the memory budget (memory_budget_bytes()), and a dataset of more than
  /// 16 MiB must have at least 1/4000 of its declared bytes stored in the file
  /// (deflate cannot compress beyond ~1032:1, even zeros; an unwritten or forged
  /// extent is refused). Throws InputError naming the file, the dataset and both sizes.
  void check_declared(const std::string& dataset) const;

  template <class T>
  H5Array<T> read(const std::string& dataset) const {
    H5Array<T> a;
    check_declared(dataset);
    a.dims = dims(dataset);
    std::size_t n = 1;
    for (auto d : a.dims) n *= d;
    a.data.resize(n);
    read_into(dataset, a.data.data());
    return a;
  }

  void set_attribute(const std::string& object, const std::string& name, const std::string& value);
  void set_attribute(const std::string& object, const std::string& name, const char* value) {
    set_attribute(object, name, std::string(value));
  }
  void set_attribute(const std::string& object, const std::string& name, double value);
  void set_attribute(const std::string& object, const std::string& name, std::int64_t value);
  void set_attribute(const std::string& object, const std::string& name,
                     const std::vector<double>& value);
  bool has_attribute(const std::string& object, const std::string& name) const;
  std::vector<std::string> attribute_names(const std::string& object) const;
  std::string attribute_string(const std::string& object, const std::string& name) const;
  /// A root attribute as a number (a numeric attribute, or text that parses as one),
  /// NaN if absent or not a number.
  double root_number(const std::string& name) const;
  /// A root attribute as text (a number formatted as in CSV headers), "" if absent.
  std::string root_text(const std::string& name) const;
  double attribute_double(const std::string& object, const std::string& name) const;
  std::int64_t attribute_int(const std::string& object, const std::string& name) const;
  std::vector<double> attribute_doubles(const std::string& object, const std::string& name) const;

 private:
  H5File(std::int64_t id, std::string path) : id_(id), path_(std::move(path)) {}
  void check_size(const std::string& dataset, const std::vector<std::size_t>& dims,
                  std::size_t n) const;
  void write_raw(const std::string& dataset, const std::vector<std::size_t>& dims,
                 std::int64_t mem_type, std::int64_t file_type, const void* data);
  void read_raw(const std::string& dataset, std::int64_t mem_type, void* data) const;
  void read_record_raw(const std::string& dataset, std::size_t index, std::int64_t mem_type,
                       void* out) const;
  void create_chunked(const std::string& dataset, const std::vector<std::size_t>& record_dims, Type type,
                      std::size_t chunk_records, int compression_level);
  void append_raw(const std::string& dataset, std::int64_t mem_type, const void* records, std::size_t count = 1);
  void read_into(const std::string& dataset, float* out) const;
  void read_into(const std::string& dataset, double* out) const;
  void read_into(const std::string& dataset, std::int64_t* out) const;
  void read_into(const std::string& dataset, std::int32_t* out) const;
  void read_into(const std::string& dataset, std::uint8_t* out) const;

  std::int64_t id_ = -1;
  std::string path_;
};

}  // namespace shearzone::io
