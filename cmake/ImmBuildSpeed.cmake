# SPDX-License-Identifier: Apache-2.0
# What makes a build of the whole tree cheaper without changing what it builds.
#
# IMM_CCACHE (default ON): compile through ccache when it is installed (scripts/install-deps.sh
# installs it) and no launcher was given. Paths below the source folder are hashed relative to
# it (CCACHE_BASEDIR), so a fresh clone in another folder hits the same cache entries. The
# compiler output is the same with or without it.
option(IMM_CCACHE "Compile through ccache when it is installed" ON)
if(IMM_CCACHE AND NOT CMAKE_CXX_COMPILER_LAUNCHER)
  find_program(IMM_CCACHE_PROGRAM ccache)
  if(IMM_CCACHE_PROGRAM)
    set(imm_launcher ${CMAKE_COMMAND} -E env CCACHE_BASEDIR=${PROJECT_SOURCE_DIR}
                     CCACHE_NOHASHDIR=1 ${IMM_CCACHE_PROGRAM})
    set(CMAKE_C_COMPILER_LAUNCHER ${imm_launcher})
    set(CMAKE_CXX_COMPILER_LAUNCHER ${imm_launcher})
    message(STATUS "immtrain: compiling through ${IMM_CCACHE_PROGRAM}")
  endif()
endif()

# IMM_MODE_COUNT_KERNELS (default ON): the banks' IMM cycles (runtime/src/tracking/imm_cycle.hpp,
# with_mode_count) are compiled once per common mode count (1–4, loops unrolled) besides the
# generic kernel that runs any count. OFF compiles the generic kernel alone: the same statements
# in the same order, so the same numbers, a little slower. The sanitizer build (`make
# test-sanitize`) turns it off: under ASan and the fuzzers' coverage the specializations took
# 5–10× the compile time of their files (the GA-fuzzy bank's 139 s against 14 s, TrackBank's
# kernel 132 s against 28 s, the FCM-IMM bank's 100 s against 11 s), while every statement they
# hold is the generic kernel's.
option(IMM_MODE_COUNT_KERNELS "Specialize the banks' kernels for 1-4 modes" ON)
if(NOT IMM_MODE_COUNT_KERNELS)
  add_compile_definitions(IMM_GENERIC_MODE_COUNT)
endif()

# IMM_UNITY_BUILD (default OFF): each target's sources compiled in batches of
# IMM_UNITY_BATCH_SIZE, one translation unit per batch (CMake's unity build). A cold build of the
# whole tree parses the headers and instantiates the same Eigen expressions once per batch rather
# than once per file. Sources with their own compile options (the banks' kernels, the OpenMP-SIMD
# files) stay on their own. The same code is compiled: IEEE arithmetic without contraction
# (-ffp-contract=off) does not depend on where a function is inlined. Off by default, where one
# changed file would rebuild its whole batch; .ci/run builds both trees with it.
option(IMM_UNITY_BUILD "Compile each target's sources in batches (cold builds)" OFF)
set(IMM_UNITY_BATCH_SIZE 8 CACHE STRING "Sources per batch of the unity build")
# A batch includes its sources by absolute path, so __FILE__ (every GoogleTest assertion, every
# assert of the Sanitize build) would name the clone's folder and ccache would miss in a clone
# elsewhere: the folder is mapped away (ccache hashes the mapped text).
if(IMM_UNITY_BUILD)
  set(CMAKE_UNITY_BUILD ON)
  set(CMAKE_UNITY_BUILD_BATCH_SIZE ${IMM_UNITY_BATCH_SIZE})
  add_compile_options(-fmacro-prefix-map=${PROJECT_SOURCE_DIR}/=)
endif()
