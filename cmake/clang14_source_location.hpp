// std::source_location for clang 14 with libstdc++ 12 (Debian 12's clang, used for fuzzing).
// libstdc++'s <source_location> needs __builtin_source_location, which clang 15 added; with
// clang 14 it defines nothing. The top-level CMakeLists.txt force-includes this header into
// every C++ translation unit when the compiler is clang older than 15 (never with gcc): it
// provides std::source_location as libstdc++'s experimental one, built on __builtin_FILE,
// __builtin_FUNCTION and __builtin_LINE (same members; column() is 0).
#pragma once

#include <source_location>

#if !defined(__cpp_lib_source_location)
#include <experimental/source_location>
namespace std {
using source_location = std::experimental::source_location;
}  // namespace std
#endif
