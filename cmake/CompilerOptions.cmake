# Warnings, -Werror, sanitizers and ccache for every draco target.

find_program(CCACHE_PROGRAM ccache)
if(CCACHE_PROGRAM)
  set(CMAKE_CXX_COMPILER_LAUNCHER ${CCACHE_PROGRAM})
endif()

add_library(draco_options INTERFACE)
target_compile_options(draco_options INTERFACE
  -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wcast-align
  -Woverloaded-virtual -Wimplicit-fallthrough
  # Options structs are filled with designated initializers; every member has a default.
  -Wno-missing-field-initializers
  # GCC 12 reports false -Wrestrict positives inside std::string at -O3 (GCC bug 105651).
  $<$<CXX_COMPILER_ID:GNU>:-Wno-restrict>)
if(DRACO_WERROR)
  target_compile_options(draco_options INTERFACE -Werror)
endif()
# Sanitizers apply to every target of the project (libraries, apps, tests, generated IDL
# code), so they are directory-wide options rather than draco_options.
string(TOLOWER "${DRACO_SANITIZE}" draco_sanitize)
# Test timeouts (tests/) are multiplied by this: sanitized code runs 2-15x slower.
set(DRACO_TEST_TIMEOUT_FACTOR 1)
if(draco_sanitize STREQUAL "thread")
  set(DRACO_TEST_TIMEOUT_FACTOR 4)
  add_compile_options(-fsanitize=thread -fno-omit-frame-pointer)
  add_link_options(-fsanitize=thread)
elseif(draco_sanitize MATCHES "^(on|yes|true|1|address)$")
  set(DRACO_TEST_TIMEOUT_FACTOR 4)
  add_compile_options(
    -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=all)
  add_link_options(-fsanitize=address,undefined -fno-sanitize-recover=all)
  # Eigen's aligned_malloc/aligned_free must match the libraries that hand Eigen heap memory
  # to draco (libceres: ceres::GradientChecker::ProbeResults, Problem::Evaluate's matrices).
  # Debian builds them without ASan, where Eigen 3.4 (Eigen/src/Core/util/Memory.h) uses plain
  # malloc/free because glibc's malloc is 16-byte aligned. Under ASan, Memory.h drops that path
  # (`! defined(__SANITIZE_ADDRESS__)`) and uses handmade_aligned_malloc, which stores the
  # original pointer in the 8 bytes before the block: freeing a libceres matrix from draco
  # then reads before a plain malloc block (heap-buffer-overflow), and a matrix draco
  # allocates would reach libceres's free() with an offset pointer. ASan's malloc is 16-byte
  # aligned too (checked by tests/sanitize), so the glibc path is right here as well:
  # EIGEN_MALLOC_ALREADY_ALIGNED=1 gives the same allocator as the libraries. It holds only
  # while EIGEN_DEFAULT_ALIGN_BYTES is 16 (no -mavx / -march=native), which tests/sanitize
  # also asserts at compile time.
  add_compile_definitions(EIGEN_MALLOC_ALREADY_ALIGNED=1)
elseif(NOT draco_sanitize MATCHES "^(off|no|false|0|)$")
  message(FATAL_ERROR "DRACO_SANITIZE=${DRACO_SANITIZE}: use OFF, ON/address or thread")
endif()

# draco_add_library(name SOURCES ... [DEPS ...])
# A static library whose translation units may register components: consumers
# link it whole-archive so the static registrations are never dropped.
function(draco_component_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(${name} STATIC ${ARG_SOURCES})
  target_link_libraries(${name} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE draco_options ${ARG_PRIVATE_DEPS})
  set_property(GLOBAL APPEND PROPERTY DRACO_COMPONENT_LIBRARIES ${name})
endfunction()

# Links every registered component library, whole-archive, into target.
function(draco_link_all_components target)
  get_property(libs GLOBAL PROPERTY DRACO_COMPONENT_LIBRARIES)
  foreach(lib ${libs})
    target_link_libraries(${target} PRIVATE "$<LINK_LIBRARY:WHOLE_ARCHIVE,${lib}>")
  endforeach()
endfunction()
