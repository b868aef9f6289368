# SPDX-License-Identifier: Apache-2.0
# Fails when the runtime (or a runtime-only client) links Ceres, NLopt, OpenMP, spdlog or MPI, either
# in its CMake link interface or in the shared libraries its binary needs at run time.
set(forbidden "ceres|nlopt|gomp|omp|spdlog|fmt|glog|gflags|mpi|open-pal|open-rte|pmix")

file(READ ${LINK_INTERFACE} interface)
message(STATUS "${interface}")
string(TOLOWER "${interface}" interface_lower)
if(interface_lower MATCHES "(${forbidden})")
  message(FATAL_ERROR "runtime link interface names '${CMAKE_MATCH_1}':\n${interface}")
endif()

find_program(READELF readelf REQUIRED)
foreach(binary ${BINARIES})
  execute_process(COMMAND ${READELF} -d ${binary} OUTPUT_VARIABLE dynamic RESULT_VARIABLE status)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "readelf failed on ${binary}")
  endif()
  string(REGEX MATCHALL "\\(NEEDED\\)[^\n]*" needed "${dynamic}")
  message(STATUS "${binary}: ${needed}")
  string(TOLOWER "${needed}" needed_lower)
  if(needed_lower MATCHES "(${forbidden})")
    message(FATAL_ERROR "${binary} needs '${CMAKE_MATCH_1}' at run time:\n${needed}")
  endif()
  if(NOT needed_lower MATCHES "libc\\.so")
    message(FATAL_ERROR "${binary}: no libc in the NEEDED list — is the check reading the right file?\n${needed}")
  endif()
endforeach()
