# SPDX-License-Identifier: Apache-2.0
# Fails when a source file (tests too) grows past 500 lines (split it by concept), or when a
# file or a symbol is named after a source paper's number ("seed000_…", "Seed003…") instead of
# what it is.
#
#   cmake -DSOURCE_DIR=<root> [-DMIN_FILES=<n>] -P check_sources.cmake
#
# A line is what `wc -l` counts (blank lines too). MIN_FILES (default 100) guards against a wrong
# root; check_sources_selftest.cmake runs this script on a small tree of its own.
cmake_minimum_required(VERSION 3.22)
set(max_lines 500)
if(NOT DEFINED MIN_FILES)
  set(MIN_FILES 100)
endif()
set(problems "")
set(count 0)
foreach(top runtime bindings support datasets trainer evaluation pipeline tools tests configs)
  file(GLOB_RECURSE found RELATIVE "${SOURCE_DIR}" "${SOURCE_DIR}/${top}/*")
  foreach(relative ${found})
    if(relative MATCHES "(^|/)[Ss]eed_?[0-9][0-9][0-9]")
      string(APPEND problems "${relative}: named after a paper's number\n")
    endif()
    if(NOT relative MATCHES "\\.(cpp|hpp|py)$")
      continue()
    endif()
    math(EXPR count "${count} + 1")
    # Every line counts, blank ones too (file(STRINGS) would skip them): the newlines, plus a
    # last line without one.
    file(READ "${SOURCE_DIR}/${relative}" text)
    string(REGEX REPLACE "[^\n]" "" newlines "${text}")
    string(LENGTH "${newlines}" length)
    if(NOT text STREQUAL "" AND NOT text MATCHES "\n$")
      math(EXPR length "${length} + 1")
    endif()
    if(length GREATER max_lines)
      string(APPEND problems "${relative}: ${length} lines (at most ${max_lines})\n")
    endif()
    # Identifiers (not prose): seed000_plots, BM_Seed003Step, seed004_regime(…).
    file(STRINGS "${SOURCE_DIR}/${relative}" named REGEX "[A-Za-z_][Ss]eed_?[0-9][0-9][0-9]|(^|[^A-Za-z ])[Ss]eed_?[0-9][0-9][0-9][A-Za-z_]")
    foreach(line ${named})
      string(STRIP "${line}" line)
      if(NOT line MATCHES "^//")
        string(APPEND problems "${relative}: a symbol named after a paper's number: ${line}\n")
      endif()
    endforeach()
  endforeach()
endforeach()
if(count LESS MIN_FILES)
  message(FATAL_ERROR "only ${count} source files under ${SOURCE_DIR}: is SOURCE_DIR the root?")
endif()
message(STATUS "checked ${count} source files")
if(problems)
  message(FATAL_ERROR "${problems}")
endif()
