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
  # UBSan leaves Eigen's headers alone under Clang (cmake/ubsan-eigen.ignorelist says why); GCC
  # has no special-case lists and checks them too.
  if(CMAKE_CXX_COMPILER_ID STREQUAL "Clang" AND IMM_SANITIZERS MATCHES "undefined")
    add_compile_options(
      $<$<COMPILE_LANGUAGE:CXX>:-fsanitize-ignorelist=${PROJECT_SOURCE_DIR}/cmake/ubsan-eigen.ignorelist>)
  endif()
  message(STATUS "immtrain: sanitizers ${IMM_SANITIZERS}")
endif()

if(IMM_FUZZERS)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "IMM_FUZZERS needs Clang (libFuzzer); configure with CXX=clang++")
  endif()
  # Edge coverage everywhere; comparison tracing (trace-cmp, which makes every comparison a call
  # and keeps loops from vectorizing) only where fuzz inputs are parsed: imm_fuzz_compare_tracing
  # below. With it everywhere the sanitized suite ran about 2.7 times slower (the runtime's
  # allocation tests: 24.5–26.4 s against 6.6–9.0 s).
  add_compile_options(-fsanitize=fuzzer-no-link -fno-sanitize-coverage=trace-cmp)
  message(STATUS "immtrain: fuzz targets linked with libFuzzer")
endif()

# imm_fuzz_compare_tracing(<source>...): sources of this directory that parse the fuzz targets'
# input byte by byte (file formats, TOML, CSV, manifests) keep libFuzzer's comparison tracing, by
# which it finds the magic values and keys their branches wait for.
function(imm_fuzz_compare_tracing)
  if(IMM_FUZZERS)
    set_property(SOURCE ${ARGN} APPEND PROPERTY COMPILE_OPTIONS -fsanitize-coverage=trace-cmp)
  endif()
endfunction()
