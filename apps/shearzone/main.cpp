// shearzone: one binary, one subcommand per pipeline stage (`shearzone <subcommand>`).
#include "common/run_app.hpp"
#include "shearzone/core/metadata.hpp"
#include "shearzone/io/image.hpp"
#include "subcommands.hpp"

int main(int argc, char** argv) {
  using namespace shearzone::apps;
  // Third-party libraries print their own lines on stderr (FFmpeg "moov atom not
  // found", OpenCV warnings) and decode images of any declared size: silenced and
  // limited before anything is opened (a user who sets these variables keeps them).
  shearzone::io::configure_decoders();
  Context ctx;
  ctx.command_line = shearzone::core::command_line_from_argv(argc, argv);
  Command command(ctx);
  return run_app(command.app(), argc, argv, [&] { return command.dispatch(); });
}
