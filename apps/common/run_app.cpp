#include "run_app.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <new>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/io/toml_config.hpp"

namespace shearzone::apps {
namespace {

void print_error(const std::string& message) {
  std::string m = message;
  std::replace(m.begin(), m.end(), '\n', ' ');
  std::fprintf(stderr, "shearzone: error: %s\n", m.c_str());
}

/// NaN is never a value a user means (it read as "not given" in places): every option
/// of every subcommand refuses a value that reads as NaN, on the command line and in
/// --config alike (a TOML value runs the same validators).
void refuse_nan_everywhere(CLI::App& app) {
  static const CLI::Validator not_nan(
      [](std::string& text) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(text.c_str(), &end);
        if (!text.empty() && end == text.c_str() + text.size() && std::isnan(v))
          return "NaN is not a value: give a number";
        return {};
      },
      "", "not NaN");
  for (CLI::Option* opt : app.get_options())
    if (opt->get_expected_max() > 0) opt->check(not_nan);
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) refuse_nan_everywhere(*sub);
}

}  // namespace

void parse_words(CLI::App& app, const std::vector<std::string>& words) {
  // argc/argv, as main gives them (the vector overload of CLI11 2.1 trips a GCC 12 -O3
  // null-dereference false positive)
  std::vector<std::string> copy = words;
  std::vector<char*> argv;
  for (std::string& w : copy) argv.push_back(w.data());
  app.parse(static_cast<int>(argv.size()), argv.data());
}

int run_words(CLI::App& app, const std::vector<std::string>& words, const std::function<int()>& dispatch) {
  refuse_nan_everywhere(app);
  try {
    parse_words(app, words);
    return dispatch();
  } catch (const CLI::ParseError& e) {
    std::string m = e.what();
    std::replace(m.begin(), m.end(), '\n', ' ');
    throw ConfigError(m);
  }
}

int run_app(CLI::App& app, int argc, char** argv, const std::function<int()>& dispatch) {
  refuse_nan_everywhere(app);
  try {
    try {
      app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
      if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
      print_error(std::string(e.what()) + " (run with --help for usage)");
      return kExitUsage;
    }
    return dispatch();
  } catch (const CLI::ParseError& e) {
    // Raised after parsing, e.g. a required option missing from flags and config.
    print_error(std::string(e.what()) + " (run with --help for usage)");
    return kExitUsage;
  } catch (const InputError& e) {
    print_error(e.what());
    return kExitInputError;
  } catch (const ConfigError& e) {
    print_error(e.what());
    return kExitInputError;
  } catch (const NoResultError& e) {
    print_error(e.what());
    return kExitNoResult;
  } catch (const std::bad_alloc&) {
    print_error("out of memory");
    return kExitInternal;
  } catch (const std::exception& e) {
    print_error(std::string("internal error: ") + e.what());
    return kExitInternal;
  }
}

void apply_toml_config(CLI::App& sub, const std::string& path,
                       const std::vector<std::string>& not_configurable) {
  const io::TomlConfig cfg = io::TomlConfig::load(path);

  // The keys this subcommand knows: its long option names without the dashes.
  std::vector<std::string> known;
  for (const CLI::Option* opt : sub.get_options()) {
    for (const std::string& name : opt->get_lnames())
      if (std::find(not_configurable.begin(), not_configurable.end(), name) ==
          not_configurable.end())
        known.push_back(name);
  }
  cfg.require_known(known);

  for (const std::string& key : cfg.keys()) {
    CLI::Option* opt = sub.get_option_no_throw("--" + key);
    if (opt == nullptr || opt->count() > 0) continue;  // the command line wins
    const auto& values = cfg.texts(key);
    try {
      if (opt->get_expected_min() == 0) {  // a flag
        if (values.size() != 1 || (values[0] != "true" && values[0] != "false"))
          throw CLI::ValidationError(key, "expected true or false");
        if (values[0] == "true") {
          opt->add_result(std::string("true"));
          opt->run_callback();
        }
        continue;
      }
      opt->add_result(values);
      opt->run_callback();
    } catch (const CLI::Error& e) {
      throw ConfigError(fmt::format("{}:{}: key \"{}\": {}", cfg.source(), cfg.line(key), key,
                                    e.what()));
    }
  }
}

void require_option(CLI::App& sub, const std::string& name) {
  const CLI::Option* opt = sub.get_option_no_throw("--" + name);
  if (opt != nullptr && opt->count() == 0)
    throw CLI::RequiredError("--" + name + " is required: give it on the command line or in --config",
                             CLI::ExitCodes::RequiredError);
}

void configure(CLI::App& sub, const std::string& config, const std::vector<std::string>& required) {
  if (!config.empty()) apply_toml_config(sub, config);
  for (const auto& name : required) require_option(sub, name);
}

std::vector<std::pair<std::string, std::string>> parse_key_values(const std::vector<std::string>& items,
                                                                  const std::string& option) {
  std::vector<std::pair<std::string, std::string>> out;
  for (const auto& kv : items) {
    const auto eq = kv.find('=');
    if (eq == std::string::npos || eq == 0)
      throw ConfigError(fmt::format("{} \"{}\": expected KEY=VALUE", option, kv));
    out.emplace_back(kv.substr(0, eq), kv.substr(eq + 1));
  }
  return out;
}

}  // namespace shearzone::apps
