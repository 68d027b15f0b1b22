// Atomic outputs: temporary file + rename, with cleanup on exceptions and signals.
//
// Signal cleanup. A registry of pending temporary paths lives in a linked list of
// fixed-size nodes. Registration and release happen in normal context under a
// mutex; the signal handler only reads (atomic flags, fixed char buffers) and calls
// unlink()/rmdir(), which are async-signal-safe. Nodes are never freed, only
// reused, so the handler never sees freed memory.
#include "shearzone/io/atomic_output.hpp"

#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <csignal>
#include <cstring>
#include <mutex>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"

namespace fs = std::filesystem;

namespace shearzone::io {
namespace {

struct RegistryNode {
  std::atomic<bool> active{false};
  bool is_dir = false;
  char path[4096] = {};
  std::atomic<RegistryNode*> next{nullptr};
};

std::atomic<RegistryNode*> g_head{nullptr};
std::mutex g_registry_mutex;
std::vector<RegistryNode*> g_nodes;  // index = slot; guarded by g_registry_mutex
std::once_flag g_handlers_once;
std::atomic<bool> g_host_handles_signals{false};

extern "C" void cleanup_on_signal(int sig) {
  // Pass 1: files; pass 2: (now empty) staging folders.
  for (int pass = 0; pass < 2; ++pass) {
    for (RegistryNode* n = g_head.load(); n != nullptr; n = n->next.load()) {
      if (!n->active.load()) continue;
      if (pass == 0 && !n->is_dir) ::unlink(n->path);
      if (pass == 1 && n->is_dir) ::rmdir(n->path);
    }
  }
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}

void install_handlers() {
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) {
    struct sigaction old {};
    sigaction(sig, nullptr, &old);
    if (old.sa_handler == SIG_IGN) continue;  // e.g. nohup: keep ignoring
    struct sigaction sa {};
    sa.sa_handler = cleanup_on_signal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = 0;
    sigaction(sig, &sa, nullptr);
  }
}

int register_path(const fs::path& p, bool is_dir) {
  if (!g_host_handles_signals.load()) std::call_once(g_handlers_once, install_handlers);
  const std::string s = p.string();
  std::lock_guard lock(g_registry_mutex);
  RegistryNode* node = nullptr;
  int slot = -1;
  for (std::size_t i = 0; i < g_nodes.size(); ++i) {
    if (!g_nodes[i]->active.load()) {
      node = g_nodes[i];
      slot = static_cast<int>(i);
      break;
    }
  }
  if (node == nullptr) {
    node = new RegistryNode();  // never freed: the signal handler may walk it at any time
    node->next.store(g_head.load());
    g_head.store(node);
    g_nodes.push_back(node);
    slot = static_cast<int>(g_nodes.size() - 1);
  }
  if (s.size() >= sizeof(node->path)) return -1;  // too long to register; RAII still cleans up
  std::memcpy(node->path, s.c_str(), s.size() + 1);
  node->is_dir = is_dir;
  node->active.store(true);
  return slot;
}

void release_slot(int slot) {
  if (slot < 0) return;
  std::lock_guard lock(g_registry_mutex);
  g_nodes[static_cast<std::size_t>(slot)]->active.store(false);
}

std::atomic<unsigned> g_counter{0};

fs::path temp_name_for(const fs::path& final_path) {
  const unsigned n = g_counter.fetch_add(1);
  return final_path.parent_path() /
         fmt::format("{}.partial-{}-{}{}", final_path.stem().string(), ::getpid(), n,
                     final_path.extension().string());
}

fs::path folder_of(const fs::path& p) {
  fs::path dir = p.parent_path();
  return dir.empty() ? fs::path(".") : dir;
}

/// Whether process `pid` still runs on this machine. A zombie (killed, not yet reaped:
/// containers whose init does not reap) counts as dead; a process we may not signal as alive.
bool process_alive(long pid) noexcept {
  if (::kill(static_cast<pid_t>(pid), 0) != 0) return errno != ESRCH;
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  if (!std::getline(stat, line)) return true;
  const auto paren = line.rfind(')');  // "pid (comm) S ...": comm may hold spaces and ')'
  return !(paren != std::string::npos && paren + 2 < line.size() && line[paren + 2] == 'Z');
}

/// Removes the temporary files (or staging folders) of `final_path` that a killed
/// process left (SIGKILL runs no handler): `<stem>.partial-<pid>-<n><ext>` whose process no
/// longer exists. A study resumed after a kill then leaves no litter. Best effort.
void remove_stale_partials(const fs::path& final_path, bool is_dir) noexcept {
  std::error_code ec;
  const fs::path dir = folder_of(final_path);
  const std::string stem = is_dir ? final_path.filename().string() : final_path.stem().string();
  const std::string ext = is_dir ? std::string() : final_path.extension().string();
  const std::string prefix = stem + ".partial-";
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.size() <= prefix.size() + ext.size() || name.compare(0, prefix.size(), prefix) != 0 ||
        name.compare(name.size() - ext.size(), ext.size(), ext) != 0)
      continue;
    const std::string mid = name.substr(prefix.size(), name.size() - prefix.size() - ext.size());  // <pid>-<n>
    const auto dash = mid.find('-');
    if (dash == std::string::npos || dash == 0 || dash + 1 == mid.size() ||
        mid.find_first_not_of("0123456789-") != std::string::npos || mid.find('-', dash + 1) != std::string::npos)
      continue;
    const long pid = std::strtol(mid.substr(0, dash).c_str(), nullptr, 10);
    if (pid <= 0 || pid == ::getpid()) continue;
    if (process_alive(pid)) continue;
    std::error_code rec;
    fs::remove_all(it->path(), rec);
  }
}

}  // namespace

namespace {

void remove_created_folders(const std::vector<fs::path>& created) noexcept {
  std::error_code ec;
  for (auto it = created.rbegin(); it != created.rend(); ++it) fs::remove(*it, ec);  // only if empty
}

/// Creates the missing folders of `dir` (like mkdir -p); returns them, outermost first.
std::vector<fs::path> create_missing_folders(const fs::path& dir, const fs::path& for_output) {
  std::vector<fs::path> missing;
  std::error_code ec;
  for (fs::path d = dir.lexically_normal(); !d.empty() && !fs::exists(d, ec); d = d.parent_path()) {
    missing.push_back(d);
    if (d == d.parent_path()) break;
  }
  std::vector<fs::path> created;
  for (auto it = missing.rbegin(); it != missing.rend(); ++it) {
    if (!fs::create_directory(*it, ec) && ec) {
      remove_created_folders(created);
      throw InputError(fmt::format("{}: cannot create output folder '{}': {}", for_output.string(),
                                   it->string(), ec.message()));
    }
    created.push_back(*it);
  }
  return created;
}

}  // namespace

void leave_signals_to_the_host() { g_host_handles_signals.store(true); }

void check_output_allowed(const fs::path& path, bool force) {
  std::error_code ec;
  // Missing folders are created when the output is written; a part of the path that
  // exists as a file is an error.
  fs::path dir = folder_of(path);
  while (!dir.empty() && !fs::exists(dir, ec) && dir != dir.parent_path()) dir = dir.parent_path();
  if (!dir.empty() && fs::exists(dir, ec) && !fs::is_directory(dir, ec))
    throw InputError(fmt::format("{}: cannot write output: '{}' is not a folder", path.string(),
                                 dir.string()));
  // A symbolic link there (even one pointing nowhere) is an existing output: replacing
  // it would silently drop the link, following it would write elsewhere.
  if (fs::is_symlink(fs::symlink_status(path, ec)) && !fs::exists(path, ec))
    throw InputError(fmt::format("{}: output is a symbolic link to a missing '{}'; expected a file path "
                                 "(remove the link, or give its target)",
                                 path.string(), fs::read_symlink(path, ec).string()));
  if (fs::exists(path, ec)) {
    if (fs::is_directory(path, ec))
      throw ConfigError(fmt::format("{}: output exists and is a folder; expected a file path",
                                    path.string()));
    if (!force)
      throw ConfigError(fmt::format(
          "{}: output exists; refusing to overwrite it (use --force to replace it)",
          path.string()));
  }
}

// ---- AtomicOutput ---------------------------------------------------------------

AtomicOutput::AtomicOutput(fs::path final_path, bool force)
    : final_path_(std::move(final_path)) {
  check_output_allowed(final_path_, force);
  created_dirs_ = create_missing_folders(folder_of(final_path_), final_path_);
  remove_stale_partials(final_path_, false);
  temp_path_ = temp_name_for(final_path_);
  registry_slot_ = register_path(temp_path_, false);
}

AtomicOutput::AtomicOutput(fs::path final_path, fs::path temp_path)
    : final_path_(std::move(final_path)), temp_path_(std::move(temp_path)) {
  registry_slot_ = register_path(temp_path_, false);
}

AtomicOutput::~AtomicOutput() {
  if (!committed_) discard();
}

void AtomicOutput::discard() noexcept {
  stream_.reset();
  std::error_code ec;
  fs::remove(temp_path_, ec);
  release_slot(registry_slot_);
  registry_slot_ = -1;
  remove_created_folders(created_dirs_);
  created_dirs_.clear();
}

std::ostream& AtomicOutput::stream() {
  if (!stream_) {
    stream_ = std::make_unique<std::ofstream>(temp_path_, std::ios::binary | std::ios::trunc);
    if (!*stream_)
      throw InputError(fmt::format("{}: cannot open for writing: {}", temp_path_.string(),
                                   std::strerror(errno)));
  }
  return *stream_;
}

void AtomicOutput::commit() {
  if (committed_) return;
  if (stream_) {
    stream_->flush();
    const bool ok = static_cast<bool>(*stream_);
    stream_->close();
    if (!ok || stream_->fail())
      throw InputError(fmt::format("{}: write failed (disk full or not writable?)",
                                   final_path_.string()));
    stream_.reset();
  }
  std::error_code ec;
  if (!fs::exists(temp_path_, ec))
    throw InternalError(fmt::format("{}: nothing was written to the temporary file '{}'",
                                    final_path_.string(), temp_path_.string()));
  fs::rename(temp_path_, final_path_, ec);
  if (ec)
    throw InputError(fmt::format("{}: cannot rename temporary file into place: {}",
                                 final_path_.string(), ec.message()));
  committed_ = true;
  release_slot(registry_slot_);
  registry_slot_ = -1;
}

// ---- AtomicOutputSet --------------------------------------------------------------

AtomicOutputSet::AtomicOutputSet(fs::path dir, bool force) : dir_(std::move(dir)), force_(force) {
  std::error_code ec;
  if (fs::exists(dir_, ec)) {
    if (!fs::is_directory(dir_, ec))
      throw ConfigError(fmt::format("{}: output folder path exists and is not a folder",
                                    dir_.string()));
    return;
  }
  fs::path clean = dir_.lexically_normal();
  if (clean.filename().empty()) clean = clean.parent_path();
  remove_stale_partials(clean, true);
  const fs::path parent = folder_of(clean);
  check_output_allowed(clean, force_);
  created_dirs_ = create_missing_folders(parent, dir_);
  staging_ = clean.parent_path() /
             fmt::format("{}.partial-{}-{}", clean.filename().string(), ::getpid(),
                         g_counter.fetch_add(1));
  staging_slot_ = register_path(staging_, true);
  fs::create_directory(staging_, ec);
  if (ec) {
    release_slot(staging_slot_);
    remove_created_folders(created_dirs_);
    throw InputError(fmt::format("{}: cannot create output folder: {}", dir_.string(),
                                 ec.message()));
  }
  dir_ = clean;
}

AtomicOutputSet::~AtomicOutputSet() {
  files_.clear();  // removes uncommitted temporary files
  if (!staging_.empty() && !committed_) {
    std::error_code ec;
    fs::remove_all(staging_, ec);
  }
  release_slot(staging_slot_);
  if (!committed_) remove_created_folders(created_dirs_);
}

void AtomicOutputSet::check(const std::string& name) const {
  if (staging_.empty()) check_output_allowed(dir_ / name, force_);
}

AtomicOutput& AtomicOutputSet::add(const std::string& name) {
  check(name);
  const fs::path final_path = dir_ / name;
  fs::path temp = staging_.empty() ? temp_name_for(final_path) : staging_ / name;
  files_.push_back(std::unique_ptr<AtomicOutput>(new AtomicOutput(final_path, temp)));
  return *files_.back();
}

std::vector<fs::path> AtomicOutputSet::final_paths() const {
  std::vector<fs::path> out;
  for (const auto& f : files_) out.push_back(f->final_path());
  return out;
}

void AtomicOutputSet::commit_all() {
  if (committed_) return;
  if (staging_.empty()) {
    for (auto& f : files_) f->commit();
  } else {
    // Close every stream and check it, then move the whole folder at once.
    for (auto& f : files_) {
      if (f->stream_) {
        f->stream_->flush();
        const bool ok = static_cast<bool>(*f->stream_);
        f->stream_->close();
        if (!ok)
          throw InputError(fmt::format("{}: write failed (disk full or not writable?)",
                                       f->final_path().string()));
        f->stream_.reset();
      }
    }
    std::error_code ec;
    fs::rename(staging_, dir_, ec);
    if (ec)
      throw InputError(fmt::format("{}: cannot move staged output folder into place: {}",
                                   dir_.string(), ec.message()));
    for (auto& f : files_) {
      f->committed_ = true;
      release_slot(f->registry_slot_);
      f->registry_slot_ = -1;
    }
  }
  committed_ = true;
}

}  // namespace shearzone::io
