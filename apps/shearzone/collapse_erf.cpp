#include "subcommands.hpp"
namespace shearzone::apps {
std::vector<Subcommand> add_collapse_erf(CLI::App&, Context&) { return {}; }
}  // namespace shearzone::apps
