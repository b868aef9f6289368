# SPDX-License-Identifier: Apache-2.0
# check_sources.cmake counts lines as `wc -l` does: a 501-line file that is 20 % blank lines
# fails it, and a 500-line file whose last line has no newline passes.
#
#   cmake -DWORK_DIR=<scratch folder> -P check_sources_selftest.cmake
cmake_minimum_required(VERSION 3.22)
set(check "${CMAKE_CURRENT_LIST_DIR}/check_sources.cmake")

function(source_with lines blank_every last_newline out)
  set(text "")
  foreach(i RANGE 1 ${lines})
    math(EXPR blank "${i} % ${blank_every}")
    if(blank EQUAL 0)
      set(line "")
    else()
      set(line "int value_${i} = ${i};")
    endif()
    if(i LESS lines OR last_newline)
      string(APPEND line "\n")
    endif()
    string(APPEND text "${line}")
  endforeach()
  set(${out} "${text}" PARENT_SCOPE)
endfunction()

function(run_check lines blank_every last_newline expect_failure)
  set(root "${WORK_DIR}/check_sources_${lines}")
  file(REMOVE_RECURSE "${root}")
  source_with(${lines} ${blank_every} ${last_newline} text)
  file(WRITE "${root}/runtime/src/long.cpp" "${text}")
  execute_process(COMMAND ${CMAKE_COMMAND} -DSOURCE_DIR=${root} -DMIN_FILES=1 -P ${check}
                  RESULT_VARIABLE result OUTPUT_VARIABLE output ERROR_VARIABLE output)
  if(expect_failure)
    if(result EQUAL 0 OR NOT output MATCHES "long.cpp: ${lines} lines")
      message(FATAL_ERROR "a ${lines}-line file passed, or failed for another reason:\n${output}")
    endif()
  elseif(NOT result EQUAL 0)
    message(FATAL_ERROR "a ${lines}-line file failed:\n${output}")
  endif()
  file(REMOVE_RECURSE "${root}")
endfunction()

# Every fifth line blank (file(STRINGS) alone would see 401 lines), ending with a newline.
run_check(501 5 TRUE TRUE)
# Every third line blank, the last line without a newline.
run_check(500 3 FALSE FALSE)
message(STATUS "check_sources.cmake counts blank lines and a last line without a newline")
