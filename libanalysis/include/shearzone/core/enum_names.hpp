// shearzone/core/enum_names.hpp: an option's enumerator from its name, the one way every
// module parses one. Each enum has `const char* <x>_name(E)` (its spelling in options,
// headers and CSVs) and `E <x>_from_name(const std::string&)`, written with these.
#pragma once

#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"

namespace shearzone::core {

/// The enumerator of `values` whose name_of() is `name`; nullopt if none.
template <class E, class NameOf>
std::optional<E> enum_named(std::string_view name, std::initializer_list<E> values, NameOf&& name_of) {
  for (const E v : values)
    if (name == name_of(v)) return v;
  return std::nullopt;
}

/// As enum_named, but ConfigError `unknown <what> "<name>"; expected one of: a, b, c` when
/// `name` is none of them.
template <class E, class NameOf>
E enum_from_name(std::string_view name, std::initializer_list<E> values, NameOf&& name_of, std::string_view what) {
  if (const std::optional<E> v = enum_named(name, values, name_of)) return *v;
  std::string list;
  for (const E v : values) list += (list.empty() ? "" : ", ") + std::string(name_of(v));
  throw ConfigError(fmt::format("unknown {} \"{}\"; expected one of: {}", what, name, list));
}

}  // namespace shearzone::core
