// apps/common/run_app.hpp: the one place where exceptions become exit codes.
//
// Every failure prints exactly one line to stderr, `shearzone: error: <message>`,
// and returns the documented code (exit_codes.hpp). Library code throws; it never
// prints or exits.
#pragma once

#include <any>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>

#include "exit_codes.hpp"
#include "shearzone/core/metadata.hpp"
#include "shearzone/core/progress.hpp"

namespace shearzone::apps {

/// State shared by all subcommands of one invocation.
struct Context {
  std::string command_line;                    ///< shell-quoted argv, for output headers
  core::LogLevel level = core::LogLevel::kNormal;
  /// The study's option check: a subcommand converts and validates its options (its
  /// job's validate()) and returns 0 before reading or writing any file.
  bool check_options = false;
  /// The Python module's calls on arrays: a subcommand that takes arrays (piv, fit)
  /// hands its typed job options here, converted from its words as the command line's
  /// are, and returns 0 without reading or writing a file (std::any of the pipeline's
  /// Options struct).
  std::function<void(std::any)> capture;
  /// tool, version, command line and conventions: the start of every output header.
  core::Metadata header() const { return core::standard_metadata(command_line); }
};

/// Parses argv with `app`, then runs `dispatch` (which returns an exit code).
/// Maps: CLI::ParseError -> 1 (help and --version -> 0), InputError/ConfigError
/// -> 2, NoResultError -> 3, anything else -> 4.
int run_app(CLI::App& app, int argc, char** argv, const std::function<int()>& dispatch);

/// Parses `words` (the program name first, as argv) with `app` and runs `dispatch`, as
/// run_app does but for a caller in this process (the Python module): nothing is
/// printed and errors are thrown, a CLI::ParseError as ConfigError carrying the line
/// the command would print. Returns dispatch's exit code.
int run_words(CLI::App& app, const std::vector<std::string>& words, const std::function<int()>& dispatch);

/// Parses `words` (the program name first, as argv) with `app`: CLI::ParseError as
/// app.parse(argc, argv) throws it.
void parse_words(CLI::App& app, const std::vector<std::string>& words);

/// Applies a TOML config file to the options of `sub`: each key is a long option
/// name without the dashes ("width", "U0", "vane-angle0-deg"); arrays give several
/// values. Options given on the command line win over the file. Unknown keys and
/// invalid values are ConfigError naming the file, line and key.
void apply_toml_config(CLI::App& sub, const std::string& path,
                       const std::vector<std::string>& not_configurable = {"config", "help"});

/// Splits repeated `KEY=VALUE` option values (`--tag N=45`, `--attr m_per_px=1e-4`)
/// into pairs. Throws ConfigError naming `option` for an entry without `=` or key.
std::vector<std::pair<std::string, std::string>> parse_key_values(const std::vector<std::string>& items,
                                                                  const std::string& option);

/// Throws CLI::RequiredError (exit 1) if option `name` of `sub` was given neither on
/// the command line nor in the config file.
void require_option(CLI::App& sub, const std::string& name);

/// The start of every subcommand: applies the `--config` file `config` when one was
/// given (the command line wins), then require_option() for each of `required`.
void configure(CLI::App& sub, const std::string& config, const std::vector<std::string>& required);

}  // namespace shearzone::apps
