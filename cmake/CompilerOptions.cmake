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
if(DRACO_SANITIZE)
  target_compile_options(draco_options INTERFACE
    -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=all)
  target_link_options(draco_options INTERFACE -fsanitize=address,undefined)
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
