// `shearzone report OUT`: one self-contained HTML page of a study's, a closed loop's or a
// clip's results (scripts/report.py: warnings first, result tables, figures, vectors over
// the frames, v(r), Lissajous curves, provenance; docs/report.md).
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/core/version.hpp"
#include "shearzone/io/atomic_output.hpp"
#include "programs.hpp"
#include "subcommands.hpp"

namespace shearzone::apps {
namespace {

namespace fs = std::filesystem;

struct ReportCli {
  std::string folder, output;
  int frames = 6;
  bool force = false;
};

int run_report(ReportCli& s, const Context& ctx) {
  if (!fs::is_directory(s.folder))
    throw InputError(fmt::format("{}: no such folder; expected a study's output folder, a sim check folder or a "
                                 "folder holding piv's fields.h5",
                                 s.folder));
  const fs::path f(s.folder);
  if (!fs::is_regular_file(f / "study.json") && !fs::is_regular_file(f / "closed_loop.csv") &&
      !fs::is_regular_file(f / "fields.h5"))
    throw InputError(fmt::format("{}: none of study.json, closed_loop.csv or fields.h5; expected a study's output "
                                 "folder, a sim check folder or a folder holding piv's fields.h5",
                                 s.folder));
  const std::string output = s.output.empty() ? (fs::path(s.folder) / "report.html").string() : s.output;
  io::check_output_allowed(output, s.force);
  const fs::path script = scripts_dir() / "report.py";
  if (!fs::is_regular_file(script))
    throw ConfigError(fmt::format("{}: no report script here (set SHEARZONE_SCRIPTS to the scripts/ folder of the "
                                  "shearzone sources)",
                                  script.string()));
  // Debian's interpreter: numpy, h5py and OpenCV come from its packages.
  const fs::path python = find_program("python3", {"/usr/bin/python3"});
  if (python.empty()) throw ConfigError("python3: not found (scripts/setup.sh installs it)");
  // --shearzone: this binary, for each lab log's `laos --inspect` on the page (empty: none)
  std::vector<std::string> argv{python.string(), script.string(), s.folder, "--output", output,
                                "--frames", std::to_string(s.frames), "--version", kVersion,
                                "--shearzone", shearzone_executable().string()};
  if (ctx.level == core::LogLevel::kQuiet) argv.emplace_back("--quiet");
  std::string err;
  const int rc = run_program_capture(argv, err);
  // The script's refusal is one line "shearzone: error: ..."; a crash ends in its last line.
  while (!err.empty() && (err.back() == '\n' || err.back() == '\r')) err.pop_back();
  const std::string last = err.substr(err.find_last_of('\n') == std::string::npos ? 0 : err.find_last_of('\n') + 1);
  constexpr std::string_view kPrefix = "shearzone: error: ";
  if (rc == 2 && last.starts_with(kPrefix)) throw InputError(last.substr(kPrefix.size()));
  if (rc == 128 + SIGINT || rc == 128 + SIGTERM) {  // Ctrl-C: end as the script did (no page was made)
    std::raise(rc - 128);
    throw InternalError(fmt::format("{}: interrupted", script.string()));
  }
  if (rc != 0)
    throw InternalError(fmt::format("{} exited with status {}{}{}", script.string(), rc, last.empty() ? "" : ": ",
                                    last));
  if (!err.empty()) std::fprintf(stderr, "%s\n", err.c_str());
  return kExitOk;
}

}  // namespace

std::vector<Subcommand> add_report(CLI::App& root, Context& ctx) {
  auto s = std::make_shared<ReportCli>();
  CLI::App* c = root.add_subcommand("report", "One self-contained HTML page of a study's, a closed loop's or a "
                                              "clip's results (warnings first; docs/report.md)");
  c->add_option("folder", s->folder,
                "A study's output folder (study.json), a sim check folder (closed_loop.csv) or a folder holding "
                "piv's fields.h5")
      ->required();
  c->add_option("-o,--output", s->output, "The page (default: FOLDER/report.html)");
  c->add_option("--frames", s->frames, "Frames per clip under the slider; range: 1..50")->check(CLI::Range(1, 50));
  c->add_flag("--force", s->force, "Replace an existing page");
  return {{c, [s, &ctx] { return run_report(*s, ctx); }}};
}

}  // namespace shearzone::apps
