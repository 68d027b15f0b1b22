// shearzone/core/check.hpp: invariant checks.
//
// SHEARZONE_CHECK(cond) is always on; SHEARZONE_CHECK_OP(a, op, b) also prints both
// operands. SHEARZONE_DCHECK(cond) is on in Debug and in the test build
// (SHEARZONE_ASSERTS=ON) and compiles to nothing otherwise. A failed check throws
// InternalError, so RAII cleanup (temporary output files) still runs; the CLI maps
// it to exit code 4. Use these for bugs only: bad user input is an InputError.
#pragma once

#include <sstream>
#include <string>

#include "shearzone/core/error.hpp"

namespace shearzone::detail {
[[noreturn]] void check_failed(const char* file, int line, const std::string& what);

template <class A, class B>
[[noreturn]] void check_op_failed(const char* file, int line, const char* expr, const A& a,
                                  const B& b) {
  std::ostringstream os;
  os << expr << " (with " << a << " vs " << b << ")";
  check_failed(file, line, os.str());
}
}  // namespace shearzone::detail

#define SHEARZONE_CHECK(cond)                                             \
  do {                                                                    \
    if (!(cond)) ::shearzone::detail::check_failed(__FILE__, __LINE__, #cond); \
  } while (false)

#define SHEARZONE_CHECK_OP(a, op, b)                                                        \
  do {                                                                                      \
    const auto& sz_check_a_ = (a);                                                          \
    const auto& sz_check_b_ = (b);                                                          \
    if (!(sz_check_a_ op sz_check_b_))                                                      \
      ::shearzone::detail::check_op_failed(__FILE__, __LINE__, #a " " #op " " #b, sz_check_a_, \
                                           sz_check_b_);                                    \
  } while (false)

#if defined(SHEARZONE_ENABLE_DCHECK) || !defined(NDEBUG)
#define SHEARZONE_DCHECK(cond) SHEARZONE_CHECK(cond)
#else
#define SHEARZONE_DCHECK(cond) \
  do {                         \
  } while (false && (cond))
#endif
