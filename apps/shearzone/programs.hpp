// apps/shearzone/programs.hpp: the programs `shearzone` starts (Snakemake for `study run`,
// the report script for `report`) and where it finds its scripts. Defined in study.cpp.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace shearzone::apps {

/// The folder of the workflow, figure and report scripts: $SHEARZONE_SCRIPTS, else the
/// source tree's scripts/.
std::filesystem::path scripts_dir();

/// The first of `first` that is executable, else `name` on PATH; empty if none.
std::filesystem::path find_program(const std::string& name, const std::vector<std::filesystem::path>& first);

/// Runs argv[0] with its arguments and returns its exit status (128 + signal if killed);
/// `silent`: its stdout and stderr go to /dev/null.
int run_program(std::vector<std::string> argv, bool silent);

/// The running `shearzone` binary (/proc/self/exe); empty when the host is another
/// program (the Python module in its interpreter).
std::filesystem::path shearzone_executable();

/// Runs argv[0] as run_program does, its stdout to ours and its stderr into `err`.
int run_program_capture(std::vector<std::string> argv, std::string& err);

}  // namespace shearzone::apps
