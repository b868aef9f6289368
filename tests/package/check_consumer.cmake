# SPDX-License-Identifier: Apache-2.0
# Installs the runtime into a scratch prefix, then configures, builds and runs a separate project
# that only does find_package(immtrain) and links imm::runtime.
file(REMOVE_RECURSE ${WORK_DIR})
execute_process(COMMAND ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${WORK_DIR}/prefix
                RESULT_VARIABLE status OUTPUT_QUIET)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "cmake --install failed")
endif()
# The Python module installed with the package (IMM_BUILD_PYTHON) imports from the prefix alone
# and reads a shipped model (not under sanitizers: the interpreter would need their runtime).
if(PYTHON AND NOT SANITIZERS)
  file(GLOB_RECURSE module ${WORK_DIR}/prefix/immtrain.*.so)
  if(NOT module)
    message(FATAL_ERROR "cmake --install put no Python module immtrain under ${WORK_DIR}/prefix")
  endif()
  get_filename_component(site ${module} DIRECTORY)
  execute_process(COMMAND ${CMAKE_COMMAND} -E env PYTHONPATH=${site} ${PYTHON} -c
                          "import immtrain; print(immtrain.__file__, immtrain.verify('${SOURCE_DIR}/models/cv3_imm.h5')['kind'])"
                  RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT status EQUAL 0 OR NOT out MATCHES "${site}.*plain_imm")
    message(FATAL_ERROR "the installed module does not import or read a model:\n${out}\n${err}")
  endif()
  message(STATUS "installed module: ${out}")
endif()
# A runtime built with sanitizers (IMM_SANITIZERS) needs a consumer linked with the same ones, by
# the same compiler (two compilers' sanitizer runtimes do not mix): the sanitizer runtime must come
# first in the executable, as it would in a user's sanitized build.
set(consumer_flags "")
if(SANITIZERS)
  set(consumer_flags -DCMAKE_CXX_FLAGS=-fsanitize=${SANITIZERS} -DCMAKE_EXE_LINKER_FLAGS=-fsanitize=${SANITIZERS})
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -S ${SOURCE_DIR}/tests/package/consumer -B ${WORK_DIR}/build
                        -G ${GENERATOR} -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix -DCMAKE_BUILD_TYPE=Release
                        -DCMAKE_CXX_COMPILER=${CXX_COMPILER}
                        ${consumer_flags}
                RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "consumer configure failed:\n${out}\n${err}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} --build ${WORK_DIR}/build
                RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "consumer build failed:\n${out}\n${err}")
endif()
execute_process(COMMAND ${WORK_DIR}/build/consumer RESULT_VARIABLE status OUTPUT_VARIABLE out)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "consumer run failed:\n${out}")
endif()
message(STATUS "${out}")
# Every shipped model, loaded through imm::load_tracker against the installed package.
file(GLOB models ${SOURCE_DIR}/models/*.h5 ${SOURCE_DIR}/models/reference/*.h5)
list(SORT models)
execute_process(COMMAND ${WORK_DIR}/build/track_every_model ${models}
                RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "track_every_model failed (${status}):\n${out}\n${err}")
endif()
message(STATUS "${out}")
# The documented example (docs/integrating.md): Cartesian plots through the plain IMM, polar plots
# (range, azimuth) through the WIMM.
set(cartesian "scan,x,y\n")
set(polar "scan,range,azimuth\n")
foreach(k RANGE 0 29)
  math(EXPR x "100 + 20 * ${k}")
  string(APPEND cartesian "${k},${x}.0,50.0\n")
  math(EXPR r "30000 - 150 * ${k}")
  string(APPEND polar "${k},${r}.0,0.5\n")
endforeach()
file(WRITE ${WORK_DIR}/cartesian.csv "${cartesian}")
file(WRITE ${WORK_DIR}/polar.csv "${polar}")
foreach(pair "cv3_imm.h5;cartesian.csv" "wimm.h5;polar.csv")
  list(GET pair 0 model)
  list(GET pair 1 csv)
  execute_process(COMMAND ${WORK_DIR}/build/track_csv ${SOURCE_DIR}/models/${model} ${WORK_DIR}/${csv}
                  RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
  string(REGEX MATCHALL "updated x=" updates "${out}")
  list(LENGTH updates count)
  if(NOT status EQUAL 0 OR count LESS 25)
    message(FATAL_ERROR "track_csv ${model} ${csv} failed (${status}, ${count} updates):\n${out}\n${err}")
  endif()
endforeach()
# The same consumer built with pkg-config's flags instead of CMake's package.
find_program(PKG_CONFIG pkg-config)
if(PKG_CONFIG AND CXX_COMPILER)
  execute_process(COMMAND ${CMAKE_COMMAND} -E env PKG_CONFIG_PATH=${WORK_DIR}/prefix/lib/pkgconfig:${WORK_DIR}/prefix/lib64/pkgconfig
                          ${PKG_CONFIG} --cflags --libs immtrain-runtime
                  RESULT_VARIABLE status OUTPUT_VARIABLE flags ERROR_VARIABLE err
                  OUTPUT_STRIP_TRAILING_WHITESPACE)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "pkg-config immtrain-runtime failed:\n${err}")
  endif()
  separate_arguments(flags UNIX_COMMAND "${flags}")
  set(sanitize "")
  if(SANITIZERS)
    set(sanitize -fsanitize=${SANITIZERS})
  endif()
  execute_process(COMMAND ${CXX_COMPILER} -std=c++20 ${sanitize} ${SOURCE_DIR}/tests/package/consumer/main.cpp
                          ${flags} -o ${WORK_DIR}/consumer_pkg_config
                  RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "consumer build with pkg-config's flags failed:\n${out}\n${err}")
  endif()
  execute_process(COMMAND ${CMAKE_COMMAND} -E env LD_LIBRARY_PATH=${WORK_DIR}/prefix/lib:${WORK_DIR}/prefix/lib64
                          ${WORK_DIR}/consumer_pkg_config RESULT_VARIABLE status OUTPUT_VARIABLE out)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "consumer (pkg-config) run failed:\n${out}")
  endif()
endif()
# The licence travels with the package.
if(NOT EXISTS ${WORK_DIR}/prefix/share/doc/immtrain/LICENSE)
  message(FATAL_ERROR "the installed package has no LICENSE")
endif()
file(REMOVE_RECURSE ${WORK_DIR})
