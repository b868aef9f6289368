# SPDX-License-Identifier: Apache-2.0
# Fails when an include points up a layer. The folders are the layers, each built on those before
# it: runtime < bindings (the Python module: the runtime alone) < support < datasets < trainer <
# {evaluation, pipeline} < tools (thin mains, benchmarks). A file may include its own layer's headers and those of any layer below, but not a
# sibling's (evaluation and pipeline meet only through processes); tests may include anything.
#
#   cmake -DSOURCE_DIR=<root> -P check_layers.cmake
# prints every include that points up (file:line, the header, both layers) and fails on any.

# Layer of a source file, from its folder (first match wins).
set(layer_folders
  "runtime/"            runtime
  # The trainer's side of Python (immtrain_lab) is a front end over the evaluation, like a tool.
  "bindings/python/lab_" tools
  "bindings/"           bindings
  "support/"            support
  "datasets/"           datasets
  "trainer/"            trainer
  "evaluation/"         evaluation
  "pipeline/"           pipeline
  "tools/"              tools)
# Where each layer's public headers live (relative to SOURCE_DIR), and the generated ones.
set(layer_includes
  runtime    "runtime/include"
  support    "support/include"
  datasets   "datasets/include"
  trainer    "trainer/include"
  evaluation "evaluation/include"
  pipeline   "pipeline/include")
set(generated_headers "imm/version.hpp" runtime "imm/runtime_export.hpp" runtime
  "imm/build_info.hpp" support)
# Rank of each layer; evaluation and pipeline share one and may not include each other.
set(order runtime bindings support datasets trainer evaluation pipeline tools)
set(siblings evaluation pipeline)

function(rank_of layer out)
  list(FIND order ${layer} rank)
  set(${out} ${rank} PARENT_SCOPE)
endfunction()

function(layer_of_file relative out)
  set(folders ${layer_folders})
  set(result "")
  while(folders)
    list(POP_FRONT folders prefix layer)
    string(FIND "${relative}" "${prefix}" at)
    if(at EQUAL 0)
      set(result ${layer})
      break()
    endif()
  endwhile()
  set(${out} "${result}" PARENT_SCOPE)
endfunction()

function(layer_of_header header out)
  set(generated ${generated_headers})
  while(generated)
    list(POP_FRONT generated name layer)
    if(header STREQUAL name)
      set(${out} ${layer} PARENT_SCOPE)
      return()
    endif()
  endwhile()
  set(includes ${layer_includes})
  while(includes)
    list(POP_FRONT includes layer folder)
    if(EXISTS "${SOURCE_DIR}/${folder}/${header}")
      set(${out} ${layer} PARENT_SCOPE)
      return()
    endif()
  endwhile()
  set(${out} "" PARENT_SCOPE)
endfunction()

set(sources "")
foreach(top runtime bindings support datasets trainer evaluation pipeline tools)
  file(GLOB_RECURSE found RELATIVE "${SOURCE_DIR}" "${SOURCE_DIR}/${top}/*.cpp"
       "${SOURCE_DIR}/${top}/*.hpp")
  list(APPEND sources ${found})
endforeach()
list(LENGTH sources count)
if(count LESS 50)
  message(FATAL_ERROR "only ${count} source files under ${SOURCE_DIR}: is SOURCE_DIR the root?")
endif()

set(violations "")
set(checked 0)
foreach(relative ${sources})
  layer_of_file("${relative}" file_layer)
  if(NOT file_layer)
    string(APPEND violations "${relative}: in no layer's folder\n")
    continue()
  endif()
  rank_of(${file_layer} file_rank)
  file(STRINGS "${SOURCE_DIR}/${relative}" lines REGEX "^#include \"imm/")
  foreach(line ${lines})
    string(REGEX REPLACE "^#include \"([^\"]+)\".*" "\\1" header "${line}")
    layer_of_header("${header}" header_layer)
    math(EXPR checked "${checked} + 1")
    if(NOT header_layer)
      string(APPEND violations "${relative}: includes ${header}, which no layer provides\n")
      continue()
    endif()
    rank_of(${header_layer} header_rank)
    list(FIND siblings ${file_layer} file_sibling)
    list(FIND siblings ${header_layer} header_sibling)
    if(NOT file_sibling EQUAL -1 AND NOT header_sibling EQUAL -1
       AND NOT file_layer STREQUAL header_layer)
      string(APPEND violations
             "${relative} (${file_layer}) includes ${header} (${header_layer}): a sibling layer\n")
    elseif(header_rank GREATER file_rank)
      string(APPEND violations
             "${relative} (${file_layer}) includes ${header} (${header_layer}): points up\n")
    endif()
  endforeach()
endforeach()

message(STATUS "checked ${checked} includes of ${count} files against ${order}")
if(violations)
  message(FATAL_ERROR "includes that point up a layer:\n${violations}")
endif()
