#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <fstream>
#include <stdexcept>
#include <string>

#include <catch2/catch.hpp>

#include "shearzone/core/error.hpp"
#include "shearzone/io/atomic_output.hpp"
#include "support/temp_dir.hpp"

using namespace shearzone;
using Catch::Matchers::Contains;
namespace fs = std::filesystem;

TEST_CASE("an atomic output appears only on commit", "[io][atomic]") {
  testing::TempDir dir("atomic");
  const fs::path target = dir / "out.csv";
  {
    io::AtomicOutput out(target, false);
    out.stream() << "hello\n";
    CHECK_FALSE(fs::exists(target));
    CHECK(fs::exists(out.temp_path()));
    CHECK(out.temp_path().parent_path() == target.parent_path());  // same folder: rename is atomic
    CHECK(out.temp_path().extension() == ".csv");
    out.commit();
  }
  CHECK(testing::read_file(target) == "hello\n");
  CHECK(testing::list_dir(dir.path()) == std::vector<std::string>{"out.csv"});
}

TEST_CASE("a writer that throws leaves no file behind", "[io][atomic]") {
  testing::TempDir dir("atomic");
  const fs::path target = dir / "out.csv";
  auto failing_job = [&] {
    io::AtomicOutput out(target, false);
    out.stream() << "partial data";
    throw std::runtime_error("writer failed");
  };
  CHECK_THROWS_AS(failing_job(), std::runtime_error);
  CHECK(testing::list_dir(dir.path()).empty());
}

TEST_CASE("an existing output is refused without force and left untouched", "[io][atomic]") {
  testing::TempDir dir("atomic");
  const fs::path target = dir / "out.csv";
  testing::write_file(target, "precious");
  CHECK_THROWS_MATCHES(io::AtomicOutput(target, false), ConfigError,
                       Catch::Matchers::Predicate<ConfigError>([&](const ConfigError& e) {
                         const std::string m = e.what();
                         return m.find(target.string()) != std::string::npos &&
                                m.find("--force") != std::string::npos;
                       }));
  CHECK(testing::read_file(target) == "precious");
  CHECK(testing::list_dir(dir.path()) == std::vector<std::string>{"out.csv"});

  SECTION("with force it is replaced on commit") {
    io::AtomicOutput out(target, true);
    out.stream() << "new";
    CHECK(testing::read_file(target) == "precious");
    out.commit();
    CHECK(testing::read_file(target) == "new");
  }
}

TEST_CASE("missing output folders are created, and removed again if nothing is written",
          "[io][atomic]") {
  testing::TempDir dir("atomic");
  {
    io::AtomicOutput out(dir / "exp data" / "results" / "x.csv", false);
    out.stream() << "x";
  }  // not committed
  CHECK_FALSE(fs::exists(dir / "exp data"));
  {
    io::AtomicOutput out(dir / "exp data" / "results" / "x.csv", false);
    out.stream() << "x";
    out.commit();
  }
  CHECK(fs::exists(dir / "exp data" / "results" / "x.csv"));
  {
    io::AtomicOutputSet set(dir / "a" / "b" / "run", false);
    set.add("r.txt").stream() << "r";
  }  // not committed
  CHECK_FALSE(fs::exists(dir / "a"));
  // A part of the path that is a file is an input error naming it.
  testing::write_file(dir / "plain", "f");
  CHECK_THROWS_WITH(io::AtomicOutput(dir / "plain" / "x.csv", false), Contains("plain") && Contains("not a folder"));
}

TEST_CASE("an output set into a new folder appears whole or not at all", "[io][atomic]") {
  testing::TempDir dir("atomic");
  const fs::path out_dir = dir / "run1";
  SECTION("commit") {
    io::AtomicOutputSet set(out_dir, false);
    set.add("a.txt").stream() << "a";
    set.add("b.txt").stream() << "b";
    CHECK_FALSE(fs::exists(out_dir));
    set.commit_all();
    CHECK(testing::list_dir(out_dir) == std::vector<std::string>{"a.txt", "b.txt"});
    CHECK(testing::list_dir(dir.path()) == std::vector<std::string>{"run1"});
  }
  SECTION("failure") {
    {
      io::AtomicOutputSet set(out_dir, false);
      set.add("a.txt").stream() << "a";
    }
    CHECK(testing::list_dir(dir.path()).empty());
  }
}

TEST_CASE("an output set into an existing folder refuses existing files", "[io][atomic]") {
  testing::TempDir dir("atomic");
  testing::write_file(dir / "a.txt", "old");
  io::AtomicOutputSet set(dir.path(), false);
  CHECK_THROWS_AS(set.add("a.txt"), ConfigError);
  set.add("b.txt").stream() << "b";
  set.commit_all();
  CHECK(testing::read_file(dir / "a.txt") == "old");
  CHECK(testing::read_file(dir / "b.txt") == "b");
}

TEST_CASE("Ctrl-C during a write leaves no partial file", "[io][atomic]") {
  testing::TempDir dir("atomic");
  const fs::path target = dir / "out.csv";
  const fs::path set_dir = dir / "frames";
  const pid_t pid = ::fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    // Child: start two outputs (a single file and a staged folder), then get SIGINT.
    io::AtomicOutput out(target, false);
    out.stream() << "partial" << std::flush;
    io::AtomicOutputSet set(set_dir, false);
    set.add("frame_0.png").stream() << "x" << std::flush;
    std::raise(SIGINT);
    ::_exit(0);  // not reached
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  CHECK(WIFSIGNALED(status));
  CHECK(WTERMSIG(status) == SIGINT);
  CHECK(testing::list_dir(dir.path()).empty());
}

TEST_CASE("a temporary file that a killed process left is removed by the next writer", "[io][atomic]") {
  // SIGKILL runs no handler: its <stem>.partial-<pid>-<n><ext> stays. A child that has
  // exited stands for the killed writer (its pid no longer exists).
  testing::TempDir dir("atomic_stale");
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  int status = 0;
  ::waitpid(child, &status, 0);
  // and a zombie (killed, not yet reaped: a container's init may never reap it) is as dead
  const pid_t zombie = ::fork();
  if (zombie == 0) ::_exit(0);
  for (int i = 0; i < 200; ++i) {  // until it has exited (state Z)
    std::ifstream st("/proc/" + std::to_string(zombie) + "/stat");
    std::string line;
    std::getline(st, line);
    if (line.find(") Z") != std::string::npos) break;
    ::usleep(10000);
  }
  testing::write_file(dir / ("out.partial-" + std::to_string(zombie) + "-7.csv"), "half too");
  const std::string dead = "out.partial-" + std::to_string(child) + "-0.csv";
  const std::string alive = "out.partial-" + std::to_string(::getppid()) + "-3.csv";  // a live process
  testing::write_file(dir / dead, "half");
  testing::write_file(dir / alive, "busy");
  testing::write_file(dir / "other.partial-1-0.csv", "another output's");
  fs::create_directory(dir / ("run.partial-" + std::to_string(child) + "-1"));  // a staging folder
  {
    io::AtomicOutput out(dir / "out.csv", false);
    out.stream() << "whole\n";
    out.commit();
  }
  io::AtomicOutputSet set(dir / "run", false);
  set.commit_all();
  ::waitpid(zombie, &status, 0);
  CHECK(testing::list_dir(dir.path()) ==
        std::vector<std::string>{"other.partial-1-0.csv", "out.csv", alive, "run"});
}

// Issue 34: a dangling link at the output path was replaced silently by one command and
// an internal error in another; any link to nothing is refused, with or without --force.
TEST_CASE("an output path that is a link to nothing is refused", "[io][atomic]") {
  testing::TempDir dir("atomic_link");
  const fs::path link = dir / "out.csv";
  fs::create_symlink(dir / "missing" / "target.csv", link);
  for (bool force : {false, true}) {
    CHECK_THROWS_AS(io::check_output_allowed(link, force), InputError);
    CHECK_THROWS_WITH(io::check_output_allowed(link, force),
                      Contains("out.csv: output is a symbolic link to a missing"));
  }
  CHECK(fs::is_symlink(fs::symlink_status(link)));  // left as it was
}
