# SPDX-License-Identifier: Apache-2.0
# Runs doxygen with docs/Doxyfile (output into WORK_DIR) and fails on any warning: every public
# class and function of the runtime documented, every reference resolved.
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
file(WRITE ${WORK_DIR}/Doxyfile "@INCLUDE = ${SOURCE_DIR}/docs/Doxyfile\nOUTPUT_DIRECTORY = ${WORK_DIR}\nWARN_LOGFILE = ${WORK_DIR}/warnings.txt\n")
execute_process(COMMAND ${DOXYGEN} ${WORK_DIR}/Doxyfile WORKING_DIRECTORY ${SOURCE_DIR}
                RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "doxygen failed (${status}):\n${out}\n${err}")
endif()
file(READ ${WORK_DIR}/warnings.txt warnings)
if(NOT warnings STREQUAL "")
  message(FATAL_ERROR "doxygen warnings:\n${warnings}")
endif()
if(NOT EXISTS ${WORK_DIR}/html/index.html)
  message(FATAL_ERROR "doxygen wrote no html/index.html")
endif()
message(STATUS "doxygen: no warnings; ${WORK_DIR}/html/index.html")
