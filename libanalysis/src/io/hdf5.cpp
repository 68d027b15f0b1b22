// HDF5 helpers on the C API, with RAII handles and errors that name the object.
#include "shearzone/io/hdf5.hpp"

#include <hdf5.h>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <vector>
#include <mutex>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/io/csv.hpp"

static_assert(sizeof(hid_t) == sizeof(std::int64_t), "hid_t is expected to be 64-bit");

// The sanitizers' report channel in a sanitized build; absent (null) otherwise.
extern "C" void __sanitizer_set_report_fd(void* fd) __attribute__((weak));

namespace shearzone::io {
namespace {

void silence_hdf5() {
  static std::once_flag once;
  std::call_once(once, [] { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); });
}

/// Closes an HDF5 handle of any kind on scope exit.
class Handle {
 public:
  explicit Handle(hid_t id = -1) : id_(id) {}
  ~Handle() {
    if (id_ >= 0) H5Oclose_any(id_);
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  hid_t get() const { return id_; }
  bool ok() const { return id_ >= 0; }

 private:
  static void H5Oclose_any(hid_t id) {
    switch (H5Iget_type(id)) {
      case H5I_FILE: H5Fclose(id); break;
      case H5I_GROUP: H5Gclose(id); break;
      case H5I_DATASET: H5Dclose(id); break;
      case H5I_DATASPACE: H5Sclose(id); break;
      case H5I_DATATYPE: H5Tclose(id); break;
      case H5I_ATTR: H5Aclose(id); break;
      case H5I_GENPROP_LST: H5Pclose(id); break;
      default: break;
    }
  }
  hid_t id_;
};

[[noreturn]] void fail(const std::string& file, const std::string& what) {
  throw InputError(fmt::format("{}: {}", file, what));
}

std::vector<hsize_t> to_hsize(const std::vector<std::size_t>& dims) {
  return std::vector<hsize_t>(dims.begin(), dims.end());
}

/// Checks the addresses of a superblock at offset 0 against the file's size before
/// HDF5 follows them: a corrupt 7 kB file whose driver-information address pointed
/// into the superblock made HDF5 1.10 allocate 4 GB over 9 s (found by fuzz_field_h5).
/// Superblock versions 0/1 (what libhdf5 writes by default) and 2/3, 8-byte offsets.
void check_superblock(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  unsigned char b[112] = {};
  in.read(reinterpret_cast<char*>(b), sizeof(b));
  const auto got = static_cast<std::size_t>(in.gcount());
  static const unsigned char sig[8] = {0x89, 'H', 'D', 'F', '\r', '\n', 0x1a, '\n'};
  if (got < 48 || std::memcmp(b, sig, 8) != 0) return;  // elsewhere (user block): HDF5 checks
  std::error_code ec;
  const auto size = static_cast<std::uint64_t>(std::filesystem::file_size(path, ec));
  auto addr = [&](std::size_t at) {
    std::uint64_t v = 0;
    for (int k = 7; k >= 0; --k) v = (v << 8) | b[at + static_cast<std::size_t>(k)];
    return v;
  };
  constexpr std::uint64_t kUndefined = ~std::uint64_t{0};
  const int version = b[8];
  std::uint64_t eof = 0, sb_end = 0;
  std::vector<std::pair<const char*, std::uint64_t>> inside;
  if ((version == 0 || version == 1) && b[13] == 8) {
    const std::size_t base = version == 0 ? 24 : 28;
    if (got < base + 48) return;
    eof = addr(base + 16);
    sb_end = base + 32 + 40;  // four addresses, then the root group's symbol table entry
    inside = {{"free-space address", addr(base + 8)}, {"driver information address", addr(base + 24)},
              {"root group address", addr(base + 40)}};
  } else if ((version == 2 || version == 3) && b[9] == 8) {
    eof = addr(28);
    sb_end = 48;
    inside = {{"superblock extension address", addr(20)}, {"root group address", addr(36)}};
  } else {
    return;
  }
  if (eof != kUndefined && eof > size)
    fail(path.string(), fmt::format("not a valid HDF5 file: its superblock declares {} bytes, the file has {}",
                                    eof, size));
  for (const auto& [what, a] : inside)
    if (a != kUndefined && (a >= size || a < sb_end))
      fail(path.string(), fmt::format("not a valid HDF5 file: superblock {} {} lies outside [{}, {}) bytes",
                                      what, a, sb_end, size));
}

/// Checks the local heaps (a group's link names; signature "HEAP", version 0, 8-byte
/// lengths and offsets) in the file's first MiB, where libhdf5 writes a group's heap when
/// it creates the group: each heap's data segment must lie inside the file. One flipped
/// bit of a heap's size in a 40 kB tracks file made HDF5 1.10 ask for 16 GiB (found by
/// fuzz_track_h5). Heaps further in are left to HDF5.
void check_local_heaps(const std::filesystem::path& path) {
  constexpr std::size_t kScanBytes = std::size_t{1} << 20;
  std::ifstream in(path, std::ios::binary);
  std::vector<char> b(kScanBytes);
  in.read(b.data(), static_cast<std::streamsize>(b.size()));
  const auto got = static_cast<std::size_t>(in.gcount());
  std::error_code ec;
  const auto size = static_cast<std::uint64_t>(std::filesystem::file_size(path, ec));
  auto u64 = [&](std::size_t at) {
    std::uint64_t v = 0;
    for (int k = 7; k >= 0; --k) v = (v << 8) | static_cast<unsigned char>(b[at + static_cast<std::size_t>(k)]);
    return v;
  };
  for (std::size_t i = 0; i + 32 <= got; ++i) {
    // The signature and version 0 (HDF5 ignores the three reserved bytes after it: a
    // heap whose reserved bytes a fuzzer had set made HDF5 1.10 ask for 16 GiB); a
    // free-list offset that is undefined or inside the segment (text that happens to
    // read "HEAP" is not a heap).
    if (std::memcmp(b.data() + i, "HEAP\0", 5) != 0) continue;
    const std::uint64_t data_size = u64(i + 8), free_list = u64(i + 16), data_addr = u64(i + 24);
    if (free_list != ~std::uint64_t{0} && free_list >= data_size && data_size <= size) continue;
    if (data_addr > size || data_size > size - data_addr)
      fail(path.string(), fmt::format("not a valid HDF5 file: the local heap at byte {} declares {} bytes at {}, "
                                      "the file has {}",
                                      i, data_size, data_addr, size));
  }
}

/// Reads one attribute's type, dataspace and (up to 1 MiB) value, as the readers do.
void walk_attribute(hid_t attr_id) {
  Handle attr(attr_id);
  if (!attr.ok()) return;
  Handle type(H5Aget_type(attr.get()));
  Handle space(H5Aget_space(attr.get()));
  if (!type.ok() || !space.ok() || H5Tis_variable_str(type.get()) > 0) return;
  const hssize_t n = H5Sget_simple_extent_npoints(space.get());
  const std::size_t elem = H5Tget_size(type.get());
  constexpr hsize_t kMaxBytes = hsize_t{1} << 20;
  if (n <= 0 || elem == 0 || H5Aget_storage_size(attr.get()) > kMaxBytes ||
      static_cast<hsize_t>(n) * elem > kMaxBytes)
    return;
  std::vector<unsigned char> buf(static_cast<std::size_t>(n) * elem);
  (void)H5Aread(attr.get(), type.get(), buf.data());
}

/// Walks one object's metadata as the readers will: its attributes, opened by index as
/// H5File opens them, and for a dataset its dataspace, type, layout and chunk index.
herr_t walk_object(hid_t parent, const char* name, const H5O_info_t* info, void*) {
  Handle obj(H5Oopen(parent, name, H5P_DEFAULT));
  if (!obj.ok()) return 0;
  for (hsize_t i = 0; i < info->num_attrs && i < 4096; ++i)
    walk_attribute(H5Aopen_by_idx(obj.get(), ".", H5_INDEX_NAME, H5_ITER_INC, i, H5P_DEFAULT, H5P_DEFAULT));
  if (info->type != H5O_TYPE_DATASET) return 0;
  Handle space(H5Dget_space(obj.get()));
  Handle type(H5Dget_type(obj.get()));
  Handle plist(H5Dget_create_plist(obj.get()));
  if (space.ok()) (void)H5Sget_simple_extent_npoints(space.get());
  if (plist.ok() && H5Pget_layout(plist.get()) == H5D_CHUNKED) {
    hsize_t chunks = 0;
    (void)H5Dget_num_chunks(obj.get(), H5S_ALL, &chunks);
  }
  return 0;
}

/// Opens the file and walks all of its metadata (every object header, attribute,
/// dataspace, type, layout and chunk index) in a child process before this process
/// opens it. HDF5 1.10 is not hardened against corrupt files: fuzzing found crashes in
/// H5Fopen itself (a root object header read past its buffer, fuzz_track_h5 in CI) after
/// the superblock and heap checks above had each closed one earlier finding. What HDF5
/// reports as an error is left to the reads that follow, which name the object.
void check_metadata_in_child(const std::filesystem::path& path) {
  constexpr double kSeconds = 8.0;  // within the 10 s that bad input may take
  detail::run_in_child(path.string(), "reading its metadata", kSeconds, [&] {
    const hid_t id = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    if (id < 0) return;
    (void)H5Ovisit2(id, H5_INDEX_NAME, H5_ITER_INC, walk_object, nullptr, H5O_INFO_ALL);
    (void)H5Fclose(id);
  });
}

}  // namespace

namespace detail {

void run_in_child(const std::string& file, const std::string& what, double seconds,
                  const std::function<void()>& work) {
  // The child holds the pipe's write end until it ends: the parent's poll wakes at its
  // end (or at the limit) without polling waitpid.
  int ends[2];
  if (pipe2(ends, O_CLOEXEC) != 0) return;
  const pid_t pid = fork();
  if (pid < 0) {
    close(ends[0]);
    close(ends[1]);
    return;
  }
  if (pid == 0) {
    close(ends[0]);
    // A crash ends the child quietly: no handler of the parent's (a sanitizer's, Python's
    // faulthandler) runs, and what libc or HDF5 would print goes nowhere.
    for (const int sig : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT}) signal(sig, SIG_DFL);
    if (const int null_fd = open("/dev/null", O_WRONLY); null_fd >= 0) {
      dup2(null_fd, STDERR_FILENO);
      // A sanitizer's reports too (under libFuzzer they go to a copy of stderr, which a
      // forked child would reopen as a stray file ".<pid>" in the working folder).
      if (__sanitizer_set_report_fd != nullptr)
        __sanitizer_set_report_fd(reinterpret_cast<void*>(static_cast<std::uintptr_t>(null_fd)));
    }
    try {
      work();
    } catch (...) {
      _exit(1);
    }
    _exit(0);  // no atexit handlers: the parent's open HDF5 files are not the child's to flush
  }
  close(ends[1]);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  bool ended = false;
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    pollfd p{ends[0], POLLIN, 0};
    const int n = poll(&p, 1, static_cast<int>(std::max<long long>(0, left.count())));
    if (n > 0) {
      ended = true;
      break;
    }
    if (n == 0 || errno != EINTR) break;
  }
  close(ends[0]);
  if (!ended) kill(pid, SIGKILL);
  int status = 0;
  pid_t done = 0;
  while ((done = waitpid(pid, &status, 0)) < 0 && errno == EINTR) {
  }
  if (!ended) fail(file, fmt::format("not a valid HDF5 file: {} took over {:g} s", what, seconds));
  if (done < 0) return;  // reaped elsewhere (SIGCHLD ignored by the host program): no verdict
  if (WIFSIGNALED(status))
    fail(file, fmt::format("not a valid HDF5 file: HDF5 crashed {} (signal {})", what, WTERMSIG(status)));
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    fail(file, fmt::format("not a valid HDF5 file: HDF5 failed {}", what));
}

}  // namespace detail

H5File H5File::open_read(const std::filesystem::path& path) {
  silence_hdf5();
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) fail(path.string(), "no such file");
  if (H5Fis_hdf5(path.c_str()) <= 0) fail(path.string(), "not an HDF5 file (or truncated)");
  check_superblock(path);
  check_local_heaps(path);
  check_metadata_in_child(path);
  hid_t id = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (id < 0) fail(path.string(), "cannot open as HDF5 (corrupt or truncated?)");
  return H5File(id, path.string());
}

H5File H5File::create(const std::filesystem::path& path) {
  silence_hdf5();
  hid_t id = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  if (id < 0) fail(path.string(), "cannot create HDF5 file (folder missing or not writable?)");
  return H5File(id, path.string());
}

H5File::H5File(H5File&& other) noexcept : id_(other.id_), path_(std::move(other.path_)) {
  other.id_ = -1;
}

H5File& H5File::operator=(H5File&& other) noexcept {
  if (this != &other) {
    if (id_ >= 0) H5Fclose(id_);
    id_ = other.id_;
    path_ = std::move(other.path_);
    other.id_ = -1;
  }
  return *this;
}

H5File::~H5File() {
  if (id_ >= 0) H5Fclose(id_);
}

void H5File::close() {
  if (id_ < 0) return;
  const herr_t flush = H5Fflush(id_, H5F_SCOPE_LOCAL);
  const herr_t status = H5Fclose(id_);
  id_ = -1;
  if (flush < 0 || status < 0) fail(path_, "error while closing HDF5 file (disk full?)");
}

bool H5File::exists(const std::string& object) const {
  if (object == "/" || object.empty()) return true;
  // Check every prefix: H5Lexists fails on a path whose parent does not exist.
  std::size_t pos = 0;
  while ((pos = object.find('/', pos + 1)) != std::string::npos) {
    if (H5Lexists(id_, object.substr(0, pos).c_str(), H5P_DEFAULT) <= 0) return false;
  }
  return H5Lexists(id_, object.c_str(), H5P_DEFAULT) > 0;
}

void H5File::check_size(const std::string& dataset, const std::vector<std::size_t>& dims,
                        std::size_t n) const {
  std::size_t want = 1;
  for (auto d : dims) want *= d;
  if (want != n)
    throw InternalError(fmt::format("{}: dataset \"{}\": {} elements given for dims of {}",
                                    path_, dataset, n, want));
}

void H5File::write_raw(const std::string& dataset, const std::vector<std::size_t>& dims,
                       std::int64_t mem_type, std::int64_t file_type, const void* data) {
  const auto hd = to_hsize(dims);
  Handle space(H5Screate_simple(static_cast<int>(hd.size()), hd.data(), nullptr));
  Handle lcpl(H5Pcreate(H5P_LINK_CREATE));
  H5Pset_create_intermediate_group(lcpl.get(), 1);
  // No modification times in the objects: the same data gives the same bytes.
  Handle dcpl(H5Pcreate(H5P_DATASET_CREATE));
  H5Pset_obj_track_times(dcpl.get(), 0);
  Handle dset(H5Dcreate2(id_, dataset.c_str(), file_type, space.get(), lcpl.get(), dcpl.get(),
                         H5P_DEFAULT));
  if (!dset.ok()) fail(path_, fmt::format("dataset \"{}\": cannot create (exists already?)", dataset));
  if (H5Dwrite(dset.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0)
    fail(path_, fmt::format("dataset \"{}\": write failed", dataset));
}

void H5File::write(const std::string& d, const std::vector<std::size_t>& dims, const float* p) {
  write_raw(d, dims, H5T_NATIVE_FLOAT, H5T_IEEE_F32LE, p);
}
void H5File::write(const std::string& d, const std::vector<std::size_t>& dims, const double* p) {
  write_raw(d, dims, H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE, p);
}
void H5File::write(const std::string& d, const std::vector<std::size_t>& dims,
                   const std::int64_t* p) {
  write_raw(d, dims, H5T_NATIVE_INT64, H5T_STD_I64LE, p);
}
void H5File::write(const std::string& d, const std::vector<std::size_t>& dims,
                   const std::int32_t* p) {
  write_raw(d, dims, H5T_NATIVE_INT32, H5T_STD_I32LE, p);
}
void H5File::write(const std::string& d, const std::vector<std::size_t>& dims,
                   const std::uint8_t* p) {
  write_raw(d, dims, H5T_NATIVE_UINT8, H5T_STD_U8LE, p);
}

namespace {
hid_t file_type_of(H5File::Type type) {
  switch (type) {
    case H5File::Type::kFloat32: return H5T_IEEE_F32LE;
    case H5File::Type::kFloat64: return H5T_IEEE_F64LE;
    case H5File::Type::kInt64: return H5T_STD_I64LE;
    case H5File::Type::kUInt8: return H5T_STD_U8LE;
  }
  return H5T_IEEE_F32LE;
}
}  // namespace

void H5File::create_appendable(const std::string& dataset,
                               const std::vector<std::size_t>& record_dims, Type type,
                               int compression_level) {
  create_chunked(dataset, record_dims, type, 1, compression_level);
}

void H5File::create_column(const std::string& dataset, Type type, std::size_t chunk_records,
                           int compression_level) {
  create_chunked(dataset, {}, type, std::max<std::size_t>(chunk_records, 1), compression_level);
}

void H5File::create_chunked(const std::string& dataset, const std::vector<std::size_t>& record_dims, Type type,
                            std::size_t chunk_records, int compression_level) {
  std::vector<hsize_t> dims{0}, maxdims{H5S_UNLIMITED}, chunk{chunk_records};
  for (std::size_t d : record_dims) {
    dims.push_back(d);
    maxdims.push_back(d);
    chunk.push_back(std::max<hsize_t>(d, 1));
  }
  Handle space(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), maxdims.data()));
  Handle dcpl(H5Pcreate(H5P_DATASET_CREATE));
  H5Pset_chunk(dcpl.get(), static_cast<int>(chunk.size()), chunk.data());
  H5Pset_obj_track_times(dcpl.get(), 0);  // the same data gives the same bytes
  if (compression_level > 0) H5Pset_deflate(dcpl.get(), static_cast<unsigned>(compression_level));
  Handle lcpl(H5Pcreate(H5P_LINK_CREATE));
  H5Pset_create_intermediate_group(lcpl.get(), 1);
  Handle dset(H5Dcreate2(id_, dataset.c_str(), file_type_of(type), space.get(), lcpl.get(), dcpl.get(),
                         H5P_DEFAULT));
  if (!dset.ok()) fail(path_, fmt::format("dataset \"{}\": cannot create (exists already?)", dataset));
}

void H5File::append_raw(const std::string& dataset, std::int64_t mem_type, const void* records, std::size_t count) {
  if (count == 0) return;
  Handle dset(H5Dopen2(id_, dataset.c_str(), H5P_DEFAULT));
  if (!dset.ok()) fail(path_, fmt::format("dataset \"{}\": not found for append", dataset));
  Handle space(H5Dget_space(dset.get()));
  const int rank = H5Sget_simple_extent_ndims(space.get());
  std::vector<hsize_t> dims(static_cast<std::size_t>(rank));
  H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr);
  std::vector<hsize_t> new_dims = dims;
  new_dims[0] += count;
  if (H5Dset_extent(dset.get(), new_dims.data()) < 0)
    fail(path_, fmt::format("dataset \"{}\": cannot extend", dataset));
  Handle fspace(H5Dget_space(dset.get()));
  const hsize_t n = count;
  std::vector<hsize_t> start(static_cast<std::size_t>(rank), 0), count_dims = dims;
  start[0] = dims[0];
  count_dims[0] = n;
  H5Sselect_hyperslab(fspace.get(), H5S_SELECT_SET, start.data(), nullptr, count_dims.data(), nullptr);
  Handle mspace(H5Screate_simple(rank, count_dims.data(), nullptr));
  if (H5Dwrite(dset.get(), mem_type, mspace.get(), fspace.get(), H5P_DEFAULT, records) < 0)
    fail(path_, fmt::format("dataset \"{}\": append failed (disk full?)", dataset));
}

void H5File::append(const std::string& d, const float* r) { append_raw(d, H5T_NATIVE_FLOAT, r); }
void H5File::append(const std::string& d, const double* r) { append_raw(d, H5T_NATIVE_DOUBLE, r); }
void H5File::append(const std::string& d, const std::int64_t* r) {
  append_raw(d, H5T_NATIVE_INT64, r);
}
void H5File::append(const std::string& d, const std::uint8_t* r) {
  append_raw(d, H5T_NATIVE_UINT8, r);
}
void H5File::append(const std::string& d, const double* r, std::size_t n) { append_raw(d, H5T_NATIVE_DOUBLE, r, n); }
void H5File::append(const std::string& d, const std::int64_t* r, std::size_t n) {
  append_raw(d, H5T_NATIVE_INT64, r, n);
}
void H5File::append(const std::string& d, const std::uint8_t* r, std::size_t n) {
  append_raw(d, H5T_NATIVE_UINT8, r, n);
}

std::size_t memory_budget_bytes() {
  if (const char* env = std::getenv("SHEARZONE_MEMORY_MB")) {
    char* end = nullptr;
    const double mb = std::strtod(env, &end);
    if (end != env && *end == '\0' && mb > 0 && std::isfinite(mb))
      return static_cast<std::size_t>(mb * 1024.0 * 1024.0);
    throw ConfigError(fmt::format("SHEARZONE_MEMORY_MB = \"{}\": expected a positive number of MiB", env));
  }
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGESIZE);
  if (pages > 0 && page > 0) return static_cast<std::size_t>(pages) * static_cast<std::size_t>(page) / 4;
  return std::size_t{1} << 30;
}

namespace {

void check_raw_chunks(const std::string& path, const std::string& dataset, hid_t dset, hid_t dcpl, hid_t space,
                      const hsize_t* chunk, int rank, double chunk_bytes) {
  // A chunk stored unfiltered (no filters, or every filter skipped in its mask) is
  // copied as is: it must hold a whole chunk, or HDF5 1.10 reads past its end (a
  // 187-byte chunk of 32 kB, its deflate message lost; found by fuzz_track_h5).
  const int nfilters = H5Pget_nfilters(dcpl);
  const unsigned all_skipped = nfilters >= 32 ? ~0u : (1u << static_cast<unsigned>(std::max(nfilters, 0))) - 1u;
  std::array<hsize_t, H5S_MAX_RANK> extent{}, at{};
  if (H5Sget_simple_extent_dims(space, extent.data(), nullptr) != rank) return;
  hsize_t nchunks = 0;
  if (H5Dget_num_chunks(dset, space, &nchunks) < 0 || nchunks == 0) return;
  constexpr double kMaxGrid = 1 << 20;  // chunk positions looked up, one B-tree search each
  double grid = 1;
  for (int k = 0; k < rank; ++k) {
    const auto i = static_cast<std::size_t>(k);
    if (chunk[i] == 0) return;
    grid *= std::ceil(static_cast<double>(extent[i]) / static_cast<double>(chunk[i]));
  }
  if (grid > kMaxGrid)
    fail(path, fmt::format("dataset \"{}\" spans {:.3g} chunks, above {:.3g}: a damaged file", dataset, grid,
                            kMaxGrid));
  while (true) {
    unsigned mask = 0;
    haddr_t addr = HADDR_UNDEF;
    hsize_t size = 0;
    if (H5Dget_chunk_info_by_coord(dset, at.data(), &mask, &addr, &size) >= 0 && addr != HADDR_UNDEF &&
        (nfilters == 0 || (mask & all_skipped) == all_skipped) && static_cast<double>(size) != chunk_bytes)
      fail(path, fmt::format("dataset \"{}\": a chunk stored unfiltered holds {} bytes, {:.0f} expected: a "
                              "damaged file",
                              dataset, size, chunk_bytes));
    int k = rank - 1;  // the next chunk position, last dimension fastest
    for (; k >= 0; --k) {
      const auto i = static_cast<std::size_t>(k);
      at[i] += chunk[i];
      if (at[i] < extent[i]) break;
      at[i] = 0;
    }
    if (k < 0) return;
  }
}

}  // namespace

void H5File::check_declared(const std::string& dataset) const {
  if (!exists(dataset)) fail(path_, fmt::format("dataset \"{}\": not found", dataset));
  Handle dset(H5Dopen2(id_, dataset.c_str(), H5P_DEFAULT));
  if (!dset.ok()) fail(path_, fmt::format("dataset \"{}\": cannot open (is it a group?)", dataset));
  Handle space(H5Dget_space(dset.get()));
  const hssize_t n = H5Sget_simple_extent_npoints(space.get());
  Handle type(H5Dget_type(dset.get()));
  const std::size_t elem = type.ok() ? H5Tget_size(type.get()) : 8;
  if (n < 0) fail(path_, fmt::format("dataset \"{}\": unreadable dataspace", dataset));
  const double declared = static_cast<double>(n) * static_cast<double>(std::max<std::size_t>(elem, 1));
  const double budget = static_cast<double>(memory_budget_bytes());
  if (declared > budget)
    fail(path_, fmt::format("dataset \"{}\" declares {} values ({:.3g} MiB), above the memory budget of "
                            "{:.3g} MiB (SHEARZONE_MEMORY_MB)",
                            dataset, n, declared / 1048576.0, budget / 1048576.0));
  constexpr double kMaxCompression = 4000.0;  // deflate cannot exceed ~1032:1, even on zeros
  const double stored = static_cast<double>(H5Dget_storage_size(dset.get()));
  // The layout: HDF5 1.10 trusts it. A compact dataset whose stored bytes are fewer
  // than its dataspace needs is read past its end (found by fuzz_track_h5), and a
  // chunk is allocated (and filled) whole however small the extent: a forged chunk
  // shape of a few GiB in a 40 kB file exhausted memory (also fuzz_track_h5).
  Handle dcpl(H5Dget_create_plist(dset.get()));
  const H5D_layout_t layout = dcpl.ok() ? H5Pget_layout(dcpl.get()) : H5D_LAYOUT_ERROR;
  if (layout == H5D_COMPACT && stored < declared)
    fail(path_, fmt::format("dataset \"{}\" declares {} values ({:.0f} bytes) but stores {:.0f} bytes: a "
                            "damaged file",
                            dataset, n, declared, stored));
  if (layout == H5D_CHUNKED) {
    // The writers chunk a record (a pair: 2 MiB for a 1080p grid of 2 px cells) or 4096 rows.
    constexpr double kMaxChunkBytes = 64.0 * 1048576.0;
    std::array<hsize_t, H5S_MAX_RANK> chunk{};
    const int rank = H5Pget_chunk(dcpl.get(), H5S_MAX_RANK, chunk.data());
    double bytes = static_cast<double>(std::max<std::size_t>(elem, 1));
    for (int k = 0; k < rank; ++k) bytes *= static_cast<double>(chunk[static_cast<std::size_t>(k)]);
    if (rank <= 0 || bytes > kMaxChunkBytes)
      fail(path_, fmt::format("dataset \"{}\" declares chunks of {:.3g} MiB, above {:.0f} MiB: a damaged "
                              "file",
                              dataset, bytes / 1048576.0, kMaxChunkBytes / 1048576.0));
    check_raw_chunks(path_, dataset, dset.get(), dcpl.get(), space.get(), chunk.data(), rank, bytes);
  }
  if (declared > 16.0 * 1048576.0 && stored * kMaxCompression < declared)
    fail(path_, fmt::format("dataset \"{}\" declares {} values ({:.3g} MiB) but the file stores {:.0f} bytes "
                            "of it: a damaged or unfinished file",
                            dataset, n, declared / 1048576.0, stored));
}

std::vector<std::size_t> H5File::dims(const std::string& dataset) const {
  if (!exists(dataset)) fail(path_, fmt::format("dataset \"{}\": not found", dataset));
  Handle dset(H5Dopen2(id_, dataset.c_str(), H5P_DEFAULT));
  if (!dset.ok()) fail(path_, fmt::format("dataset \"{}\": cannot open (is it a group?)", dataset));
  Handle space(H5Dget_space(dset.get()));
  const int rank = H5Sget_simple_extent_ndims(space.get());
  if (rank < 0) fail(path_, fmt::format("dataset \"{}\": unreadable dataspace", dataset));
  std::vector<hsize_t> hd(static_cast<std::size_t>(rank));
  H5Sget_simple_extent_dims(space.get(), hd.data(), nullptr);
  return std::vector<std::size_t>(hd.begin(), hd.end());
}

void H5File::read_raw(const std::string& dataset, std::int64_t mem_type, void* data) const {
  if (!exists(dataset)) fail(path_, fmt::format("dataset \"{}\": not found", dataset));
  Handle dset(H5Dopen2(id_, dataset.c_str(), H5P_DEFAULT));
  if (!dset.ok()) fail(path_, fmt::format("dataset \"{}\": cannot open", dataset));
  if (H5Dread(dset.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0)
    fail(path_, fmt::format("dataset \"{}\": read failed (type not convertible or file corrupt)",
                            dataset));
}

void H5File::read_record_raw(const std::string& dataset, std::size_t index, std::int64_t mem_type,
                             void* out) const {
  const std::vector<std::size_t> d = dims(dataset);
  if (d.empty() || index >= d[0])
    fail(path_, fmt::format("dataset \"{}\": record {} requested, {} present", dataset, index,
                            d.empty() ? 0 : d[0]));
  Handle dset(H5Dopen2(id_, dataset.c_str(), H5P_DEFAULT));
  Handle fspace(H5Dget_space(dset.get()));
  std::vector<hsize_t> start(d.size(), 0), count(d.begin(), d.end());
  start[0] = index;
  count[0] = 1;
  H5Sselect_hyperslab(fspace.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr);
  Handle mspace(H5Screate_simple(static_cast<int>(count.size()), count.data(), nullptr));
  if (H5Dread(dset.get(), mem_type, mspace.get(), fspace.get(), H5P_DEFAULT, out) < 0)
    fail(path_, fmt::format("dataset \"{}\": record {} unreadable (file corrupt?)", dataset, index));
}

void H5File::read_record(const std::string& d, std::size_t i, float* o) const {
  read_record_raw(d, i, H5T_NATIVE_FLOAT, o);
}
void H5File::read_record(const std::string& d, std::size_t i, double* o) const {
  read_record_raw(d, i, H5T_NATIVE_DOUBLE, o);
}
void H5File::read_record(const std::string& d, std::size_t i, std::uint8_t* o) const {
  read_record_raw(d, i, H5T_NATIVE_UINT8, o);
}

void H5File::read_into(const std::string& d, float* o) const { read_raw(d, H5T_NATIVE_FLOAT, o); }
void H5File::read_into(const std::string& d, double* o) const {
  read_raw(d, H5T_NATIVE_DOUBLE, o);
}
void H5File::read_into(const std::string& d, std::int64_t* o) const {
  read_raw(d, H5T_NATIVE_INT64, o);
}
void H5File::read_into(const std::string& d, std::int32_t* o) const {
  read_raw(d, H5T_NATIVE_INT32, o);
}
void H5File::read_into(const std::string& d, std::uint8_t* o) const {
  read_raw(d, H5T_NATIVE_UINT8, o);
}

// ---- Attributes -------------------------------------------------------------------

namespace {

hid_t open_object(hid_t file, const std::string& path, const std::string& object) {
  const std::string o = object.empty() ? "/" : object;
  hid_t id = H5Oopen(file, o.c_str(), H5P_DEFAULT);
  if (id < 0) fail(path, fmt::format("object \"{}\": not found", o));
  return id;
}

void write_attribute(hid_t file, const std::string& path, const std::string& object,
                     const std::string& name, hid_t type, hid_t space, const void* data) {
  Handle obj(open_object(file, path, object));
  if (H5Aexists(obj.get(), name.c_str()) > 0) H5Adelete(obj.get(), name.c_str());
  Handle attr(H5Acreate2(obj.get(), name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT));
  if (!attr.ok() || H5Awrite(attr.get(), type, data) < 0)
    fail(path, fmt::format("object \"{}\": cannot write attribute \"{}\"", object, name));
}

}  // namespace

void H5File::set_attribute(const std::string& object, const std::string& name,
                           const std::string& value) {
  Handle type(H5Tcopy(H5T_C_S1));
  H5Tset_size(type.get(), std::max<std::size_t>(value.size(), 1));
  H5Tset_strpad(type.get(), H5T_STR_NULLPAD);
  H5Tset_cset(type.get(), H5T_CSET_UTF8);
  Handle space(H5Screate(H5S_SCALAR));
  std::string buf = value.empty() ? std::string(1, '\0') : value;
  write_attribute(id_, path_, object, name, type.get(), space.get(), buf.data());
}

void H5File::set_attribute(const std::string& object, const std::string& name, double value) {
  Handle space(H5Screate(H5S_SCALAR));
  write_attribute(id_, path_, object, name, H5T_NATIVE_DOUBLE, space.get(), &value);
}

void H5File::set_attribute(const std::string& object, const std::string& name,
                           std::int64_t value) {
  Handle space(H5Screate(H5S_SCALAR));
  write_attribute(id_, path_, object, name, H5T_NATIVE_INT64, space.get(), &value);
}

void H5File::set_attribute(const std::string& object, const std::string& name,
                           const std::vector<double>& value) {
  hsize_t n = value.size();
  Handle space(H5Screate_simple(1, &n, nullptr));
  write_attribute(id_, path_, object, name, H5T_NATIVE_DOUBLE, space.get(), value.data());
}

bool H5File::has_attribute(const std::string& object, const std::string& name) const {
  if (!exists(object)) return false;
  Handle obj(open_object(id_, path_, object));
  return H5Aexists(obj.get(), name.c_str()) > 0;
}

std::vector<std::string> H5File::attribute_names(const std::string& object) const {
  Handle obj(open_object(id_, path_, object));
  H5O_info_t info;
  if (H5Oget_info2(obj.get(), &info, H5O_INFO_NUM_ATTRS) < 0)
    fail(path_, fmt::format("object \"{}\": cannot list attributes", object));
  std::vector<std::string> names;
  for (hsize_t i = 0; i < info.num_attrs; ++i) {
    Handle attr(H5Aopen_by_idx(obj.get(), ".", H5_INDEX_NAME, H5_ITER_INC, i, H5P_DEFAULT,
                               H5P_DEFAULT));
    const ssize_t len = H5Aget_name(attr.get(), 0, nullptr);
    std::string name(static_cast<std::size_t>(std::max<ssize_t>(len, 0)), '\0');
    H5Aget_name(attr.get(), name.size() + 1, name.data());
    names.push_back(name);
  }
  return names;
}

namespace {

hid_t open_attribute(hid_t file, const std::string& path, const std::string& object,
                     const std::string& name) {
  // The attribute stays valid after its object's handle is closed.
  Handle obj(open_object(file, path, object));
  if (H5Aexists(obj.get(), name.c_str()) <= 0)
    fail(path, fmt::format("object \"{}\": attribute \"{}\" not found", object, name));
  return H5Aopen(obj.get(), name.c_str(), H5P_DEFAULT);
}

}  // namespace

double H5File::root_number(const std::string& name) const {
  if (!has_attribute("/", name)) return std::numeric_limits<double>::quiet_NaN();
  try {
    return attribute_double("/", name);
  } catch (const InputError&) {
    double v = 0;
    return parse_number(attribute_string("/", name), false, v) ? v : std::numeric_limits<double>::quiet_NaN();
  }
}

std::string H5File::root_text(const std::string& name) const {
  if (!has_attribute("/", name)) return {};
  try {
    return attribute_string("/", name);
  } catch (const InputError&) {
    return format_number(attribute_double("/", name));
  }
}

std::string H5File::attribute_string(const std::string& object, const std::string& name) const {
  Handle attr(open_attribute(id_, path_, object, name));
  Handle ftype(H5Aget_type(attr.get()));
  if (H5Tget_class(ftype.get()) != H5T_STRING)
    fail(path_, fmt::format("object \"{}\": attribute \"{}\" is not a string", object, name));
  if (H5Tis_variable_str(ftype.get()) > 0) {
    Handle mtype(H5Tcopy(H5T_C_S1));
    H5Tset_size(mtype.get(), H5T_VARIABLE);
    char* s = nullptr;
    if (H5Aread(attr.get(), mtype.get(), &s) < 0)
      fail(path_, fmt::format("object \"{}\": attribute \"{}\": read failed", object, name));
    std::string out = s ? s : "";
    H5free_memory(s);
    return out;
  }
  const std::size_t size = H5Tget_size(ftype.get());
  std::string buf(size, '\0');
  if (H5Aread(attr.get(), ftype.get(), buf.data()) < 0)
    fail(path_, fmt::format("object \"{}\": attribute \"{}\": read failed", object, name));
  const auto nul = buf.find('\0');
  if (nul != std::string::npos) buf.resize(nul);
  return buf;
}

double H5File::attribute_double(const std::string& object, const std::string& name) const {
  Handle attr(open_attribute(id_, path_, object, name));
  double v = 0;
  if (H5Aread(attr.get(), H5T_NATIVE_DOUBLE, &v) < 0)
    fail(path_, fmt::format("object \"{}\": attribute \"{}\": not a number", object, name));
  return v;
}

std::int64_t H5File::attribute_int(const std::string& object, const std::string& name) const {
  Handle attr(open_attribute(id_, path_, object, name));
  std::int64_t v = 0;
  if (H5Aread(attr.get(), H5T_NATIVE_INT64, &v) < 0)
    fail(path_, fmt::format("object \"{}\": attribute \"{}\": not an integer", object, name));
  return v;
}

std::vector<double> H5File::attribute_doubles(const std::string& object,
                                              const std::string& name) const {
  Handle attr(open_attribute(id_, path_, object, name));
  Handle space(H5Aget_space(attr.get()));
  const hssize_t n = H5Sget_simple_extent_npoints(space.get());
  std::vector<double> v(static_cast<std::size_t>(std::max<hssize_t>(n, 0)));
  if (H5Aread(attr.get(), H5T_NATIVE_DOUBLE, v.data()) < 0)
    fail(path_, fmt::format("object \"{}\": attribute \"{}\": not numbers", object, name));
  return v;
}

}  // namespace shearzone::io
