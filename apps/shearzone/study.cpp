// `shearzone study run STUDY.toml -o OUT`: a whole study (lab clips and logs, a
// simulation grid) through the Snakemake workflow in scripts/study/, locally or on SLURM.
#include <fcntl.h>
#include <sys/file.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <thread>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/study/study.hpp"
#include "programs.hpp"
#include "subcommands.hpp"

#ifndef SHEARZONE_SOURCE_DIR
#define SHEARZONE_SOURCE_DIR ""
#endif

namespace shearzone::apps {
namespace {
namespace fs = std::filesystem;

struct StudyCli {
  std::string study, output;
  int jobs = 0;
  bool slurm = false, dry_run = false, keep_going = false;
};

/// The long options of `shearzone <stage>` ("render" is `sim render`, "erf"/"power" are
/// `fit erf|power`, "collapse" is `collapse erf`); none for an unknown stage.
std::vector<std::string> option_names(CLI::App& root, const std::string& stage) {
  CLI::App* sub = nullptr;
  try {
    if (stage == "render") sub = root.get_subcommand("sim")->get_subcommand("render");
    else if (stage == "erf" || stage == "power") sub = root.get_subcommand("fit")->get_subcommand(stage);
    else if (stage == "collapse") sub = root.get_subcommand("collapse")->get_subcommand("erf");
    else sub = root.get_subcommand(stage);
  } catch (const CLI::Error&) {
    return {};
  }
  std::vector<std::string> names;
  for (const CLI::Option* o : sub->get_options())
    for (const std::string& n : o->get_lnames()) names.push_back(n);
  return names;
}

/// Does `shearzone <stage>` have the long option --key?
bool has_option(CLI::App& root, const std::string& stage, const std::string& key) {
  const std::vector<std::string> names = option_names(root, stage);
  return std::find(names.begin(), names.end(), key) != names.end();
}

/// `shearzone <stage> ARGS` parsed and validated by the subcommand itself, on a CLI of
/// its own, with the inputs and outputs the study's jobs give it as placeholders; no
/// file is read. Throws ConfigError with the subcommand's message.
void check_stage(const std::string& stage, const std::vector<std::string>& args) {
  // The words of the subcommand and what every job of the stage adds (docs/study.md).
  static const std::map<std::string, std::vector<std::string>> kJob{
      {"piv", {"piv", "clip.mp4", "-o", "fields.h5"}},
      {"profile", {"profile", "fields.h5", "-o", "profile.csv"}},
      {"width", {"width", "profile.csv", "-o", "width.csv"}},
      {"laos", {"laos", "torque.csv", "-o", "laos"}},
      {"render", {"sim", "render", "run", "-o", "video"}},
      {"erf", {"fit", "erf", "table.csv", "-o", "erf.csv", "--x", "phi0_rad", "--y", "rc_m", "--group", "N"}},
      {"power", {"fit", "power", "table.csv", "-o", "power.csv", "--x", "N", "--y", "rc_m"}},
      {"collapse", {"collapse", "erf", "table.csv", "-o", "collapse", "--x", "phi0_rad", "--y", "rc_m", "--group",
                    "N"}},
  };
  const auto job = kJob.find(stage);
  if (job == kJob.end()) return;
  CLI::App root;
  root.name("shearzone");
  root.require_subcommand(1);
  root.fallthrough();
  Context ctx;
  ctx.check_options = true;
  ctx.level = core::LogLevel::kQuiet;
  std::vector<Subcommand> subs = add_subcommands(root, ctx);
  std::vector<std::string> words{"shearzone"};
  words.insert(words.end(), job->second.begin(), job->second.end());
  words.insert(words.end(), args.begin(), args.end());
  try {
    parse_words(root, words);
  } catch (const CLI::ParseError& e) {
    throw ConfigError(e.what());
  }
  for (auto& sub : subs)
    if (sub.app->parsed()) {
      try {
        (void)sub.run();
      } catch (const CLI::ParseError& e) {
        throw ConfigError(e.what());
      }
      return;
    }
}

/// In a forked child: replaces it by argv[0] with its arguments (exit 127 if it cannot run).
[[noreturn]] void exec_child(std::vector<std::string>& argv) {
  std::vector<char*> args;
  for (auto& a : argv) args.push_back(a.data());
  args.push_back(nullptr);
  ::execv(args[0], args.data());
  std::fprintf(stderr, "shearzone: error: cannot run %s\n", args[0]);
  ::_exit(127);
}

/// Waits for a child and returns its exit status (128 + signal if killed).
int wait_exit_status(pid_t pid, const std::string& name) {
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) throw ConfigError(fmt::format("waiting for {} failed", name));
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

/// What a failed workflow left in its log: the failed rule, its input, the job's own
/// error line.
struct WorkflowFailure {
  std::string rule, input, message, last_line;
};

/// Runs Snakemake with its output (stdout and stderr) through a pipe: every line goes to
/// `log_path`; lines go on to our stdout (progress) until Snakemake reports a failed job
/// ("Error in rule"), after which the rest (the workflow engine's 160-180 lines of a
/// failure) stays in the log. Returns the exit status.
int run_workflow(std::vector<std::string> argv, const fs::path& log_path, WorkflowFailure& failure) {
  std::ofstream log(log_path, std::ios::trunc);
  if (!log) throw ConfigError(fmt::format("{}: cannot write the workflow's log", log_path.string()));
  int fds[2];
  if (::pipe(fds) != 0) throw ConfigError("cannot start snakemake: pipe failed");
  std::fflush(nullptr);
  const pid_t pid = ::fork();
  if (pid < 0) throw ConfigError(fmt::format("cannot start {}: fork failed", argv[0]));
  if (pid == 0) {
    ::close(fds[0]);
    ::dup2(fds[1], 1);
    ::dup2(fds[1], 2);
    ::close(fds[1]);
    exec_child(argv);
  }
  ::close(fds[1]);
  bool echo = true, in_error = false;
  std::string pending, last_job_error;
  auto line_done = [&](const std::string& line) {
    log << line << '\n';
    // A job's own error line (some jobs' refusals are tolerated by the workflow, such as
    // width's exit 3): the last one before Snakemake reports a failed job is its message.
    // (our own scripts' lines too: "collect.py: error: ...")
    if (!in_error) {
      const auto tag = line.find(": error: ");
      if (tag != std::string::npos && tag > 0 && line.find_first_of(" \t") > tag)
        last_job_error = line.substr(line.rfind("shearzone: error: ", 0) == 0 ? 18 : 0);
    }
    if (line.rfind("Error in rule ", 0) == 0) {
      in_error = true;
      if (failure.rule.empty()) {
        failure.rule = line.substr(14, line.size() - 14 - (line.back() == ':' ? 1 : 0));
        failure.message = last_job_error;
      }
    } else if (in_error && failure.input.empty() && line.find("input:") != std::string::npos) {
      failure.input = line.substr(line.find("input:") + 6);
      while (!failure.input.empty() && failure.input.front() == ' ') failure.input.erase(0, 1);
    }
    if (in_error) echo = false;
    if (!line.empty() && line.find_first_not_of(' ') != std::string::npos) failure.last_line = line;
    if (echo) {
      std::fprintf(stdout, "%s\n", line.c_str());
      std::fflush(stdout);
    }
  };
  char buf[4096];
  for (;;) {
    const ssize_t n = ::read(fds[0], buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    pending.append(buf, static_cast<std::size_t>(n));
    for (std::size_t nl; (nl = pending.find('\n')) != std::string::npos;) {
      line_done(pending.substr(0, nl));
      pending.erase(0, nl + 1);
    }
  }
  if (!pending.empty()) line_done(pending);
  ::close(fds[0]);
  return wait_exit_status(pid, argv[0]);
}

int run_study(CLI::App& root, StudyCli& s, const Context& ctx) {
  const study::Study study = study::load_study(
      s.study, [&root](const std::string& stage, const std::string& key) { return has_option(root, stage, key); },
      [&root](const std::string& stage) { return option_names(root, stage); }, check_stage);
  const fs::path scripts = scripts_dir();
  const fs::path snakefile = scripts / "study" / "Snakefile";
  if (!fs::is_regular_file(snakefile))
    throw ConfigError(fmt::format("{}: no workflow here (set SHEARZONE_SCRIPTS to the scripts/ folder of the "
                                  "shearzone sources)",
                                  snakefile.string()));
  // Debian's snakemake first: a python3 earlier on PATH (pyenv) may lack its module.
  const fs::path snakemake = find_program("snakemake", {"/usr/bin/snakemake"});
  if (snakemake.empty())
    throw ConfigError("snakemake: not found (Debian 12: apt-get install snakemake, or scripts/setup.sh)");
  const fs::path python = find_program("python3", {"/usr/bin/python3"});
  std::error_code ec;
  fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (ec) self = fs::absolute(fs::path("shearzone"));
  if (fs::exists(s.output) && !fs::is_directory(s.output))
    throw ConfigError(fmt::format("{}: exists and is not a folder (expected the study's output folder)", s.output));
  const bool new_folder = !fs::exists(s.output);
  fs::create_directories(s.output);
  // One `study run` per folder at a time: an advisory lock that the kernel drops when the
  // process (and the Snakemake it starts, which inherits it) ends, even by SIGKILL. Holding
  // it proves that a Snakemake lock left in the folder is stale (a killed run): it is
  // cleared, so the same command resumes the study.
  const fs::path lock_path = fs::path(s.output) / ".study.lock";
  const int lock_fd = ::open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (lock_fd < 0) throw ConfigError(fmt::format("{}: cannot create (is the folder writable?)", lock_path.string()));
  ::fcntl(lock_fd, F_SETFD, 0);  // inherited by Snakemake: the lock lasts while it runs
  if (::flock(lock_fd, LOCK_EX | LOCK_NB) != 0)
    throw ConfigError(fmt::format("{}: another `shearzone study run` is running on this folder", s.output));
  try {
    study::write_study_plan(study, s.output, self, python, scripts);
  } catch (...) {
    std::error_code rec;
    if (new_folder) fs::remove_all(s.output, rec);  // a refusal leaves no folder behind
    throw;
  }

  const int jobs = s.jobs > 0 ? s.jobs : (s.slurm ? 50 : static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));
  std::vector<std::string> argv{snakemake.string(),
                                "--snakefile", snakefile.string(),
                                "--directory", s.output,
                                "--configfile", (fs::path(s.output) / "study.json").string(),
                                "--printshellcmds",
                                "--nocolor",
                                // a killed run's unfinished jobs are run again, not refused
                                "--rerun-incomplete"};
  if (s.slurm) {
    // scripts/study/slurm/config.yaml: the flags tested with Snakemake 7.21 and slurm-wlm
    // 22.05 (docs/study.md)
    argv.insert(argv.end(), {"--profile", (scripts / "study" / "slurm").string(), "--jobs", std::to_string(jobs)});
    if (!std::getenv("USER")) ::setenv("USER", std::to_string(::getuid()).c_str(), 0);
  } else {
    argv.insert(argv.end(), {"--cores", std::to_string(jobs)});
  }
  if (s.dry_run) argv.push_back("--dry-run");
  if (s.keep_going) argv.push_back("--keep-going");
  if (ctx.level == core::LogLevel::kQuiet) argv.push_back("--quiet");
  if (ctx.level == core::LogLevel::kVerbose) argv.push_back("--verbose");

  const fs::path locks = fs::path(s.output) / ".snakemake" / "locks";
  std::error_code lec;
  if (fs::is_directory(locks, lec) && !fs::is_empty(locks, lec)) {
    std::vector<std::string> unlock(argv.begin(), argv.begin() + 7);  // snakefile, directory, configfile
    unlock.insert(unlock.end(), {"--unlock", "--quiet"});
    if (run_program(unlock, true) != 0)
      throw ConfigError(fmt::format("{}: cannot clear the lock a killed run left (snakemake --unlock failed)", s.output));
  }
  // The workflow's whole output is kept in OUT/.snakemake/log/study_run.log (beside
  // Snakemake's own bookkeeping, outside the results); a failure is one line.
  const fs::path log_dir = fs::path(s.output) / ".snakemake" / "log";
  fs::create_directories(log_dir);
  const fs::path log_path = log_dir / "study_run.log";
  WorkflowFailure failure;
  const int rc = run_workflow(argv, log_path, failure);
  if (rc != 0) {
    std::string what;
    if (!failure.rule.empty())
      what = fmt::format("job \"{}\"{} failed: {}", failure.rule,
                         failure.input.empty() ? "" : fmt::format(" (input {})", failure.input),
                         failure.message.empty() ? "see the log" : failure.message);
    else
      what = fmt::format("the workflow stopped (snakemake exit {}): {}", rc,
                         failure.message.empty() ? failure.last_line : failure.message);
    throw NoResultError(fmt::format("{}: {}; the full log: {}; the same command resumes it", s.output, what,
                                    log_path.string()));
  }
  if (ctx.level != core::LogLevel::kQuiet && !s.dry_run) {
    std::string what = fmt::format("{} clip{}, {} torque log{}", study.clips.size(), study.clips.size() == 1 ? "" : "s",
                                   study.logs.size(), study.logs.size() == 1 ? "" : "s");
    if (!study.groups.empty())
      what += fmt::format(", {} simulated group{} x {} amplitude{}", study.groups.size(),
                          study.groups.size() == 1 ? "" : "s", study.sim_phi0_rad.size(),
                          study.sim_phi0_rad.size() == 1 ? "" : "s");
    // Refusals are results (docs/study.md): count the clips piv refused and the logs
    // LAOS skipped, whose reasons the report lists first.
    auto refused = [](const fs::path& p) {
      std::ifstream in(p, std::ios::binary);
      std::string first(10, '\0');
      in.read(first.data(), 10);
      return in && first == "# refused:";
    };
    std::size_t clips_refused = 0, logs_skipped = 0;
    for (const auto& c : study.clips)
      clips_refused += refused(fs::path(s.output) / "lab" / "clips" / c.name / "fields.h5");
    for (const auto& l : study.logs)
      logs_skipped += refused(fs::path(s.output) / "lab" / "logs" / l.name / "refused.txt");
    std::string refusals;
    if (clips_refused > 0)
      refusals += fmt::format("; {} clip{} refused by piv", clips_refused, clips_refused == 1 ? "" : "s");
    if (logs_skipped > 0)
      refusals += fmt::format("; {} torque log{} skipped", logs_skipped, logs_skipped == 1 ? "" : "s");
    std::printf("study: %s done%s -> %s (every warning: %s/report.html)\n", what.c_str(), refusals.c_str(),
                s.output.c_str(), s.output.c_str());
  }
  return kExitOk;
}

}  // namespace

/// The folder of the workflow and figure scripts: $SHEARZONE_SCRIPTS, else the source tree's.
fs::path scripts_dir() {
  if (const char* env = std::getenv("SHEARZONE_SCRIPTS"); env && *env) return env;
  return fs::path(SHEARZONE_SOURCE_DIR) / "scripts";
}

fs::path find_program(const std::string& name, const std::vector<fs::path>& first) {
  for (const fs::path& p : first)
    if (::access(p.c_str(), X_OK) == 0) return p;
  if (const char* path = std::getenv("PATH"))
    for (std::string_view rest = path; !rest.empty();) {
      const auto colon = rest.find(':');
      const fs::path p = fs::path(std::string(rest.substr(0, colon))) / name;
      if (::access(p.c_str(), X_OK) == 0) return p;
      if (colon == std::string_view::npos) break;
      rest.remove_prefix(colon + 1);
    }
  return {};
}

int run_program(std::vector<std::string> argv, bool silent) {
  std::fflush(nullptr);
  const pid_t pid = ::fork();
  if (pid < 0) throw ConfigError(fmt::format("cannot start {}: fork failed", argv[0]));
  if (pid == 0) {
    if (silent) {
      const int devnull = ::open("/dev/null", O_WRONLY);
      if (devnull >= 0) {
        ::dup2(devnull, 1);
        ::dup2(devnull, 2);
      }
    }
    exec_child(argv);
  }
  return wait_exit_status(pid, argv[0]);
}

fs::path shearzone_executable() {
  char self[4096];
  const ssize_t n = ::readlink("/proc/self/exe", self, sizeof self - 1);
  if (n <= 0) return {};
  const fs::path path(std::string(self, static_cast<std::size_t>(n)));
  return path.filename().string().rfind("shearzone", 0) == 0 ? path : fs::path();
}

int run_program_capture(std::vector<std::string> argv, std::string& err) {
  std::fflush(nullptr);
  int fds[2];
  if (::pipe(fds) != 0) throw ConfigError(fmt::format("cannot start {}: pipe failed", argv[0]));
  const pid_t pid = ::fork();
  if (pid < 0) throw ConfigError(fmt::format("cannot start {}: fork failed", argv[0]));
  if (pid == 0) {
    ::close(fds[0]);
    ::dup2(fds[1], 2);
    ::close(fds[1]);
    exec_child(argv);
  }
  ::close(fds[1]);
  char buf[4096];
  for (;;) {
    const ssize_t n = ::read(fds[0], buf, sizeof buf);
    if (n > 0) {
      err.append(buf, static_cast<std::size_t>(n));
    } else if (n == 0 || errno != EINTR) {
      break;
    }
  }
  ::close(fds[0]);
  return wait_exit_status(pid, argv[0]);
}

std::vector<Subcommand> add_study(CLI::App& root, Context& ctx) {
  CLI::App* st = root.add_subcommand("study", "A whole study (lab clips and torque logs, a simulation grid) from "
                                              "one TOML file to every result and figure, via Snakemake");
  st->require_subcommand(1);
  auto s = std::make_shared<StudyCli>();
  CLI::App* c = st->add_subcommand("run", "Run (or resume) a study: STUDY.toml -> OUT/ (docs/study.md)");
  c->add_option("study", s->study, "Study file (TOML)")->required();
  c->add_option("-o,--output", s->output, "Output folder (a rerun resumes it and runs only what changed)")->required();
  c->add_option("--jobs", s->jobs,
                "Cores used at once locally (default: all), or jobs queued at once with --slurm (default 50); "
                "range: >= 1")
      ->check(CLI::Range(1, 100000));
  c->add_flag("--slurm", s->slurm, "Submit every job to SLURM (sbatch) instead of running it here");
  c->add_flag("--dry-run", s->dry_run, "Check the study and list the jobs that would run; run nothing");
  c->add_flag("--keep-going", s->keep_going, "Go on with independent jobs after a job fails");
  return {{c, [&root, s, &ctx] { return run_study(root, *s, ctx); }}};
}

}  // namespace shearzone::apps
