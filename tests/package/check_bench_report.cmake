# SPDX-License-Identifier: Apache-2.0
# imm-bench-report with --nightly: the last night's stages (≥ 1 s) go beside the benchmark medians
# as "nightly: <stage>" in s, and one 20 % slower than the run before is flagged; the machine is
# recorded (the benchmark context's CPUs and clock, the CPU model, the threads given, the BLAS).
#   cmake -DTOOL=<imm-bench-report> -DWORK_DIR=<dir> -P check_bench_report.cmake
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
file(WRITE ${WORK_DIR}/runtime.json [=[
{"context": {"num_cpus": 3, "mhz_per_cpu": 3470, "cpu_scaling_enabled": false},
 "benchmarks": [{"name": "BM_Step_median", "run_name": "BM_Step", "run_type": "aggregate",
  "aggregate_name": "median", "real_time": 400.0, "time_unit": "ns"}]}
]=])
function(night seconds)
  file(APPEND ${WORK_DIR}/nights.jsonl
       "{\"night\":\"n\",\"exit_code\":0,\"wall_seconds\":100,\"stages\":{\"model ga\":${seconds},\"evaluation quick\":0.2}}\n")
endfunction()
function(report)
  execute_process(COMMAND ${TOOL} --out ${WORK_DIR}/latest.json --nightly ${WORK_DIR}/nights.jsonl
                          --threads imm-bench=1 ${WORK_DIR}/runtime.json
                  RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "imm-bench-report failed (${status}): ${out}${err}")
  endif()
endfunction()
# The row of `name` in latest.json as "median unit slower".
function(row name result)
  file(READ ${WORK_DIR}/latest.json doc)
  string(JSON count LENGTH "${doc}" benchmarks)
  math(EXPR last "${count} - 1")
  foreach(i RANGE ${last})
    string(JSON n GET "${doc}" benchmarks ${i} name)
    if(n STREQUAL name)
      string(JSON median GET "${doc}" benchmarks ${i} median)
      string(JSON unit GET "${doc}" benchmarks ${i} unit)
      string(JSON slower ERROR_VARIABLE none GET "${doc}" benchmarks ${i} slower)
      set(${result} "${median} ${unit} ${slower}" PARENT_SCOPE)
      return()
    endif()
  endforeach()
  set(${result} "absent" PARENT_SCOPE)
endfunction()

night(80)
report()
row("nightly: model ga" ga)
row("nightly: evaluation quick" quick)
row("BM_Step" step)
if(NOT ga MATCHES "^80(\\.0*)? s" OR NOT quick STREQUAL "absent" OR NOT step MATCHES "^400")
  message(FATAL_ERROR "first run: ga '${ga}', quick '${quick}', step '${step}'")
endif()
file(READ ${WORK_DIR}/latest.json doc)
string(JSON cpus GET "${doc}" machine logical_cpus)
string(JSON mhz GET "${doc}" machine mhz_per_cpu)
string(JSON threads GET "${doc}" machine threads imm-bench)
string(JSON model GET "${doc}" machine cpu_model)
string(JSON signature GET "${doc}" machine cpu_signature)
string(JSON blas GET "${doc}" machine blas)
if(NOT cpus EQUAL 3 OR NOT mhz MATCHES "^3470" OR NOT threads EQUAL 1 OR model STREQUAL ""
   OR blas STREQUAL "")
  message(FATAL_ERROR "machine: cpus '${cpus}', MHz '${mhz}', threads '${threads}', model "
                      "'${model}', BLAS '${blas}'")
endif()
# On x86 Linux the processor's family and model, which name its generation where a hypervisor
# shortens its name.
file(READ /proc/cpuinfo cpuinfo LIMIT 4096)
if(cpuinfo MATCHES "cpu family" AND NOT signature MATCHES "family [0-9]+ model [0-9]+")
  message(FATAL_ERROR "machine: cpu_signature '${signature}' names no family and model")
endif()
night(96)  # 20 % slower
report()
row("nightly: model ga" ga)
if(NOT ga MATCHES "^96(\\.0*)? s ON$")
  message(FATAL_ERROR "a 20 % slower training is not flagged: '${ga}'")
endif()
message(STATUS "nightly stages in latest.json: ${ga}")
