// shearzone/io/atomic_output.hpp: output files that appear whole or not at all.
//
// The rule for every output of every subcommand (README, "Output files"):
//  - An existing output is never overwritten unless `force` is true; the refusal
//    is a ConfigError naming the file (exit code 2), thrown before any work.
//  - Data is written to a temporary file in the same folder
//    (`<stem>.partial-<pid>-<n><ext>`, keeping the extension so that writers that
//    pick a format from it, like OpenCV's, still work) and renamed into place by
//    commit(). If commit() is never reached (an exception, an early return), the
//    destructor deletes the temporary file. If the process gets SIGINT, SIGTERM or
//    SIGHUP, a signal handler deletes every pending temporary file before the
//    process dies with that signal.
//
// Example:
//     io::AtomicOutput out("profile.csv", force);   // refuses if it exists
//     write_csv(out.stream(), table);               // or use out.temp_path()
//     out.commit();                                 // rename into place
//
// Not thread-safe per object; different objects may be used from different threads.
#pragma once

#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

namespace shearzone::io {

/// Throws ConfigError if `path` exists and `force` is false, and InputError if a
/// part of its folder exists as a file. Missing folders are fine: the writers below
/// create them (like `mkdir -p`) and remove those they created if the output is
/// never committed. Cheap: call it before any work.
void check_output_allowed(const std::filesystem::path& path, bool force);

/// By default the first temporary output installs handlers for SIGINT, SIGTERM and
/// SIGHUP that remove every pending temporary file and folder, then die of the signal
/// (the command killed by Ctrl-C leaves nothing behind). A host with its own handlers
/// (the Python module: Ctrl-C is a KeyboardInterrupt that unwinds the work, and the
/// destructors remove the temporaries) calls this first, once: no handler is installed.
void leave_signals_to_the_host();

class AtomicOutput {
 public:
  AtomicOutput(std::filesystem::path final_path, bool force);
  ~AtomicOutput();
  AtomicOutput(const AtomicOutput&) = delete;
  AtomicOutput& operator=(const AtomicOutput&) = delete;

  /// Where the data goes until commit(). For writers that take a path.
  const std::filesystem::path& temp_path() const { return temp_path_; }
  const std::filesystem::path& final_path() const { return final_path_; }

  /// A binary output stream on the temporary file (opened on first use).
  std::ostream& stream();

  /// Closes the stream (if used), checks that everything was written, and renames
  /// the temporary file to the final path. Throws InputError on a write failure or
  /// if the temporary file is missing (a writer that never wrote).
  void commit();
  bool committed() const { return committed_; }

 private:
  friend class AtomicOutputSet;
  AtomicOutput(std::filesystem::path final_path, std::filesystem::path temp_path);
  void discard() noexcept;

  std::filesystem::path final_path_;
  std::filesystem::path temp_path_;
  std::unique_ptr<std::ofstream> stream_;
  int registry_slot_ = -1;
  bool committed_ = false;
  std::vector<std::filesystem::path> created_dirs_;  ///< removed again unless committed
};

/// Several files in one output folder that appear together. If the folder does not
/// exist yet, files are staged in a sibling folder `<dir>.partial-<pid>-<n>` that
/// commit_all() renames to `<dir>`; if it exists, each file gets its own temporary
/// file inside it. Either way nothing appears under the final names before
/// commit_all(), and the destructor removes everything uncommitted.
class AtomicOutputSet {
 public:
  AtomicOutputSet(std::filesystem::path dir, bool force);
  ~AtomicOutputSet();
  AtomicOutputSet(const AtomicOutputSet&) = delete;
  AtomicOutputSet& operator=(const AtomicOutputSet&) = delete;

  /// Declares an output file `name` (relative to the folder). Throws ConfigError if
  /// `<dir>/<name>` exists and force is false.
  AtomicOutput& add(const std::string& name);
  /// Checks, without declaring it, that `name` may be written (same rule as add()).
  void check(const std::string& name) const;
  void commit_all();
  const std::filesystem::path& dir() const { return dir_; }
  /// Final paths of the declared files, in the order they were added.
  std::vector<std::filesystem::path> final_paths() const;

 private:
  std::filesystem::path dir_;
  std::filesystem::path staging_;  // empty when writing into an existing folder
  bool force_;
  bool committed_ = false;
  std::vector<std::filesystem::path> created_dirs_;  ///< removed again unless committed
  int staging_slot_ = -1;
  std::vector<std::unique_ptr<AtomicOutput>> files_;
};

}  // namespace shearzone::io
