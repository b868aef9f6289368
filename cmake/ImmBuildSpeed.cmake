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
