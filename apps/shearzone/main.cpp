// shearzone: one binary, one subcommand per pipeline stage (`shearzone <subcommand>`).
#include <cstdlib>

#include <CLI/CLI.hpp>

#include "common/run_app.hpp"
#include "shearzone/io/image.hpp"
#include "shearzone/core/version.hpp"
#include "subcommands.hpp"

int main(int argc, char** argv) {
  using namespace shearzone::apps;
  // Third-party libraries print their own lines on stderr (FFmpeg "moov atom not
  // found", OpenCV warnings) and decode images of any declared size: silenced and
  // limited before anything is opened (a user who sets these variables keeps them).
  shearzone::io::configure_decoders();
  CLI::App app{"shearzone: experimental rheology of granular chains (PIV, profiles, fits, LAOS, "
               "contact dynamics)"};
  app.name("shearzone");
  app.set_version_flag("--version", std::string("shearzone ") + shearzone::kVersion);
  app.require_subcommand(1);
  app.fallthrough();  // -q/-v may follow the subcommand

  Context ctx;
  ctx.command_line = shearzone::core::command_line_from_argv(argc, argv);
  bool quiet = false, verbose = false;
  app.add_flag("-q,--quiet", quiet, "Only errors on stderr; no progress, no summary");
  app.add_flag("-v,--verbose", verbose, "More detail on stderr");

  std::vector<Subcommand> subs = add_subcommands(app, ctx);

  return run_app(app, argc, argv, [&]() -> int {
    ctx.level = quiet ? shearzone::core::LogLevel::kQuiet
                      : (verbose ? shearzone::core::LogLevel::kVerbose
                                 : shearzone::core::LogLevel::kNormal);
    for (auto& s : subs)
      if (s.app->parsed()) return s.run();
    return kExitUsage;  // unreachable: CLI11 requires a subcommand
  });
}
