# SPDX-License-Identifier: Apache-2.0
# imm_target_warnings(<target>): the project's warning set, applied to its own targets only.
function(imm_target_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor
                                           -Wold-style-cast -Wcast-align -Woverloaded-virtual)
endfunction()

# imm_library(<name> <source>...): the static library imm_<name> of the project's own code, used
# as imm::<name>: position-independent (the Python modules link it, bindings/python), its
# include/ folder public, the project's warnings. Each layer adds its links and options after.
function(imm_library name)
  add_library(imm_${name} STATIC ${ARGN})
  add_library(imm::${name} ALIAS imm_${name})
  set_target_properties(imm_${name} PROPERTIES POSITION_INDEPENDENT_CODE ON)
  target_include_directories(imm_${name} PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include)
  imm_target_warnings(imm_${name})
endfunction()

# imm_pressure_scheduling(<source>...): GCC's scheduling before register allocation (off by default
# on x86), pressure-aware so that it does not spill more, for sources of this directory where it
# was measured faster. Scheduling changes no operation, so not the bits; other compilers get
# nothing. clang-tidy does not know -fsched-pressure: run it on these files with a compile
# database that leaves the flag out.
function(imm_pressure_scheduling)
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    set_property(SOURCE ${ARGN} APPEND PROPERTY COMPILE_OPTIONS -fschedule-insns -fsched-pressure)
  endif()
endfunction()
