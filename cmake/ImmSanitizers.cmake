# SPDX-License-Identifier: Apache-2.0
# Sanitizer and fuzzing builds (`make test-sanitize`, `make fuzz`; see the README).
#
# IMM_SANITIZERS: a comma-separated -fsanitize list (e.g. "address,undefined") applied to every
# target of the project, tests included. LeakSanitizer runs with AddressSanitizer on Linux. Any
# UBSan finding aborts: -fno-sanitize-recover makes it a failing test, not a line in a log.
#
# IMM_FUZZERS: instruments every target for libFuzzer's coverage feedback (Clang only) and links
# the fuzz targets under tests/fuzz/ with libFuzzer. Without it (or with GCC) the fuzz targets link
# a plain driver that replays their corpus, so they build and run as regression tests everywhere.
set(IMM_SANITIZERS "" CACHE STRING "Sanitizers for every target (-fsanitize=...), empty for none")
option(IMM_FUZZERS "Link the fuzz targets with libFuzzer (Clang)" OFF)

# The "Sanitize" build type: -O2 (Eigen's fixed-size kernels rely on inlining; at -O1 the suite
# runs tens of times slower), line tables for symbolized reports, assertions on (Eigen's bounds
# checks stay active).
# project() already created these cache entries, empty, when CMAKE_BUILD_TYPE names the type:
# fill them unless the user set them.
foreach(language C CXX)
  if(NOT CMAKE_${language}_FLAGS_SANITIZE)
    set(CMAKE_${language}_FLAGS_SANITIZE "-O2 -g1" CACHE STRING
        "${language} flags of the Sanitize build type" FORCE)
  endif()
endforeach()

if(IMM_SANITIZERS)
  add_compile_options(-fsanitize=${IMM_SANITIZERS} -fno-omit-frame-pointer
                      -fno-sanitize-recover=all)
  add_link_options(-fsanitize=${IMM_SANITIZERS})
  message(STATUS "immtrain: sanitizers ${IMM_SANITIZERS}")
endif()

if(IMM_FUZZERS)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "IMM_FUZZERS needs Clang (libFuzzer); configure with CXX=clang++")
  endif()
  add_compile_options(-fsanitize=fuzzer-no-link)
  message(STATUS "immtrain: fuzz targets linked with libFuzzer")
endif()
