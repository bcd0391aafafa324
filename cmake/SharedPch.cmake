# One precompiled header shared by many executables (tests/README.md "CI time").
#
# chromo_shared_pch(NAME HEADERS <h>... LIBRARIES <lib>... [OPTIONS <flag>...])
#   An object library whose only source is an empty anchor: it compiles the
#   headers once into a precompiled header (GCC's .gch) that every target
#   given to chromo_use_shared_pch() reuses. LIBRARIES give the headers'
#   include directories; OPTIONS are compile options the header and every
#   user get alike (-pthread: the targets that link gRPC compile with it,
#   which defines _REENTRANT, and GCC refuses a header precompiled without).
# chromo_use_shared_pch(TARGET NAME)
#   TARGET includes NAME's header first in each of its (unity) sources.
#   TARGET must compile with the same flags as NAME: the same build type,
#   options and -fopenmp or not (GCC ignores a precompiled header built with
#   other flags and parses the headers as text: slower, never wrong; the
#   libraries are linked to TARGET so that this fallback finds them).
#
# ccache caches a source compiled with a precompiled header only with
# sloppiness pch_defines,time_macros; chromo_use_shared_pch gives TARGET's
# compiler launcher that setting when the launcher is ccache.

function(chromo_shared_pch name)
  cmake_parse_arguments(ARG "" "" "HEADERS;LIBRARIES;OPTIONS" ${ARGN})
  set(anchor ${CMAKE_CURRENT_BINARY_DIR}/${name}_anchor.cpp)
  file(CONFIGURE OUTPUT ${anchor} CONTENT "// ${name}'s precompiled header is its only product (cmake/SharedPch.cmake)\n")
  add_library(${name} OBJECT ${anchor})
  target_link_libraries(${name} PRIVATE ${ARG_LIBRARIES})
  target_compile_options(${name} PRIVATE ${ARG_OPTIONS})
  target_precompile_headers(${name} PRIVATE ${ARG_HEADERS})
  set_target_properties(${name} PROPERTIES CHROMO_PCH_LIBRARIES "${ARG_LIBRARIES}" CHROMO_PCH_OPTIONS "${ARG_OPTIONS}")
  chromo_pch_ccache_launcher(${name})
endfunction()

function(chromo_use_shared_pch target name)
  get_target_property(libraries ${name} CHROMO_PCH_LIBRARIES)
  get_target_property(options ${name} CHROMO_PCH_OPTIONS)
  target_link_libraries(${target} PRIVATE ${libraries})
  target_compile_options(${target} PRIVATE ${options})
  target_precompile_headers(${target} REUSE_FROM ${name})
  chromo_pch_ccache_launcher(${target})
endfunction()

function(chromo_pch_ccache_launcher target)
  if(CMAKE_CXX_COMPILER_LAUNCHER MATCHES "ccache")
    set_target_properties(${target} PROPERTIES CXX_COMPILER_LAUNCHER
      "env;CCACHE_SLOPPINESS=pch_defines,time_macros;${CMAKE_CXX_COMPILER_LAUNCHER}")
  endif()
endfunction()
