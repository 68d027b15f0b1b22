# Interface targets that carry compile settings (no global CMAKE_CXX_FLAGS).
#
#   shearzone_warnings : warning flags (and -Werror with SHEARZONE_WARNINGS_AS_ERRORS)
#   shearzone_options  : language level, asserts, sanitizers. Never -ffast-math:
#                        input checks rely on std::isfinite.

add_library(shearzone_warnings INTERFACE)
target_compile_options(shearzone_warnings INTERFACE
  $<$<CXX_COMPILER_ID:GNU,Clang>:-Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor
                                 -Wcast-align -Wunused -Woverloaded-virtual
                                 -Wnull-dereference -Wimplicit-fallthrough>)
if(SHEARZONE_WARNINGS_AS_ERRORS)
  target_compile_options(shearzone_warnings INTERFACE $<$<CXX_COMPILER_ID:GNU,Clang>:-Werror>)
endif()

add_library(shearzone_options INTERFACE)
target_compile_features(shearzone_options INTERFACE cxx_std_20)
if(SHEARZONE_ASSERTS)
  # RelWithDebInfo adds -DNDEBUG; the test build wants assert() and SHEARZONE_DCHECK on.
  target_compile_options(shearzone_options INTERFACE -UNDEBUG)
  target_compile_definitions(shearzone_options INTERFACE SHEARZONE_ENABLE_DCHECK=1)
endif()
if(SHEARZONE_SANITIZE)
  # -g1 (line tables: the sanitizers' reports still give file and line) after the build
  # type's -g: the sanitizer build was CI's longest step, and full debug information
  # cost a fifth of its compile time (profile/lockin.cpp: 53 s with -g, 43 s with -g1).
  target_compile_options(shearzone_options INTERFACE
    -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined -g1)
  target_link_options(shearzone_options INTERFACE -fsanitize=address,undefined)
endif()
if(SHEARZONE_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "SHEARZONE_FUZZ needs clang (scripts/fuzz.sh uses clang++-14)")
  endif()
  # Coverage instrumentation for libFuzzer in the library; the targets link the driver.
  target_compile_options(shearzone_options INTERFACE -fsanitize=fuzzer-no-link)
endif()
