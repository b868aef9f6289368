# SPDX-License-Identifier: Apache-2.0
# Runs an example of docs/examples (track_a_regime.py unless -DSCRIPT names another, with
# -DARGS, a ;-list) and checks its PNG: a PNG file, at least 800 px wide, and more than a blank
# canvas (its size; matplotlib's empty figure of that size is under 10 kB).
#   cmake -DPYTHON=python3 -DSOURCE_DIR=<root> -DOUT=<png> [-DSCRIPT=x.py -DARGS=a;b] -P run_example.cmake
file(REMOVE "${OUT}")
if(NOT SCRIPT)
  set(SCRIPT track_a_regime.py)
  set(ARGS --bin $ENV{IMM_BIN})
endif()
execute_process(
  COMMAND ${PYTHON} ${SOURCE_DIR}/docs/examples/${SCRIPT} ${ARGS} --out ${OUT}
  RESULT_VARIABLE status OUTPUT_VARIABLE output ERROR_VARIABLE errors)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "the example failed (${status}):\n${output}${errors}")
endif()
message(STATUS "${output}")
if(NOT EXISTS "${OUT}")
  message(FATAL_ERROR "the example wrote no ${OUT}")
endif()
file(READ "${OUT}" header LIMIT 24 HEX)
string(SUBSTRING "${header}" 0 16 magic)
if(NOT magic STREQUAL "89504e470d0a1a0a")
  message(FATAL_ERROR "${OUT} is not a PNG (starts ${magic})")
endif()
string(SUBSTRING "${header}" 32 8 width_hex)
math(EXPR width "0x${width_hex}")
file(SIZE "${OUT}" size)
if(width LESS 800 OR size LESS 30000)
  message(FATAL_ERROR "${OUT} is ${width} px wide and ${size} bytes: not a real plot")
endif()
message(STATUS "${OUT}: ${width} px wide, ${size} bytes")
