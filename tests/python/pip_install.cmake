# SPDX-License-Identifier: Apache-2.0
# `pip install` as a Python user runs it: the package installs into a fresh virtual environment
# (python3 -m venv --system-site-packages, so that Debian's setuptools, wheel and numpy are there)
# and imports outside the source tree with its version, the runtime library of its own wheel and
# its type stubs;
# `pip wheel` writes a wheel that installs into a second environment. The build reuses this
# build's configured tree (IMMTRAIN_CMAKE_BUILD_DIR), so that the test does not compile the
# runtime again; setup.py configures build/python-wheel itself without it.
#   cmake -DPYTHON=… -DSOURCE_DIR=… -DBUILD_DIR=… -DWORK_DIR=… -P pip_install.cmake
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
set(ENV{IMMTRAIN_CMAKE_BUILD_DIR} ${BUILD_DIR})
set(ENV{PIP_NO_INDEX} 1)
set(ENV{PIP_DISABLE_PIP_VERSION_CHECK} 1)
unset(ENV{PYTHONPATH})

function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err
                  WORKING_DIRECTORY ${WORK_DIR})
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "${ARGN}: exit ${status}\n${out}\n${err}")
  endif()
  set(output "${out}" PARENT_SCOPE)
endfunction()

# The version the package must report: the CMake project's.
file(READ ${SOURCE_DIR}/CMakeLists.txt text)
string(REGEX MATCH "project\\(immtrain VERSION ([0-9.]+)" _ "${text}")
set(version ${CMAKE_MATCH_1})

# Imports from outside the source tree: prints the version, where libimmruntime came from and where
# the trainer's side (immtrain.evaluate) comes from.
set(check [=[
import immtrain
runtime = [line.split()[-1] for line in open("/proc/self/maps") if "libimmruntime" in line]
print(immtrain.__version__, runtime[0] if runtime else "none", immtrain.evaluate.__module__)
]=])
function(expect_installed venv)
  run(${venv}/bin/python -c "${check}")
  string(STRIP "${output}" output)
  separate_arguments(fields UNIX_COMMAND "${output}")
  list(GET fields 0 got)
  list(GET fields 1 library)
  list(GET fields 2 lab)
  if(NOT lab STREQUAL "immtrain_lab")
    message(FATAL_ERROR "${venv}: immtrain.evaluate comes from '${lab}', not the trainer's side "
                        "(immtrain_lab) of the package")
  endif()
  if(NOT got STREQUAL version)
    message(FATAL_ERROR "${venv}: immtrain.__version__ is '${got}', the project's is ${version}")
  endif()
  string(FIND "${library}" "${venv}/" inside)
  if(NOT inside EQUAL 0)
    message(FATAL_ERROR "${venv}: libimmruntime loaded from '${library}', not from the package")
  endif()
  file(GLOB stubs ${venv}/lib/python3*/site-packages/immtrain.pyi)
  if(NOT stubs)
    message(FATAL_ERROR "${venv}: no immtrain.pyi beside the module (the type stubs)")
  endif()
  message(STATUS "${venv}: immtrain ${got}, runtime ${library}, stubs ${stubs}")
endfunction()

run(${PYTHON} -m venv --system-site-packages ${WORK_DIR}/venv)
run(${WORK_DIR}/venv/bin/pip install --no-build-isolation --no-deps ${SOURCE_DIR})
expect_installed(${WORK_DIR}/venv)

run(${WORK_DIR}/venv/bin/pip wheel --no-build-isolation --no-deps -w ${WORK_DIR}/wheels
    ${SOURCE_DIR})
file(GLOB wheels ${WORK_DIR}/wheels/immtrain-${version}-*.whl)
if(NOT wheels)
  message(FATAL_ERROR "pip wheel wrote no immtrain-${version} wheel in ${WORK_DIR}/wheels")
endif()
run(${PYTHON} -m venv --system-site-packages ${WORK_DIR}/second)
run(${WORK_DIR}/second/bin/pip install --no-deps ${wheels})
expect_installed(${WORK_DIR}/second)
