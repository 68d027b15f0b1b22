// shearzone/core/error.hpp: the error types of the toolkit.
//
// Three kinds of failure are kept apart (see README, Exit codes):
//  1. Bad input or configuration: InputError, ConfigError. The message says where
//     (file:line, column, dataset, frame), the bad value, and what was expected.
//     The CLI maps both to exit code 2.
//  2. A run that completed but produced no usable result: NoResultError (exit 3).
//     Library stages usually report this in their Result struct instead; the
//     pipeline decides whether to throw it.
//  3. Broken invariants (bugs): InternalError, thrown by SHEARZONE_CHECK (exit 4).
//
// Library code throws and never prints or calls exit().
#pragma once

#include <stdexcept>
#include <string>

namespace shearzone {

/// Base class of every error the toolkit throws on purpose.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Bad input data: a file that is missing, unreadable or malformed, a value out of
/// range. Messages read `<file>:<line>: <what>: "<value>" <expected ...>`.
class InputError : public Error {
 public:
  using Error::Error;
};

/// Bad configuration: an option out of range, an unknown config key, an
/// inconsistent combination of options, an output that exists without --force.
class ConfigError : public Error {
 public:
  using Error::Error;
};

/// The computation ran but produced nothing usable (exit code 3).
class NoResultError : public Error {
 public:
  using Error::Error;
};

/// A broken internal invariant: a bug in shearzone, never the user's fault (exit 4).
class InternalError : public Error {
 public:
  using Error::Error;
};

}  // namespace shearzone
