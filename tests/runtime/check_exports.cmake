# SPDX-License-Identifier: Apache-2.0
# Fails when the shared runtime exports more than its API: the library is built with hidden
# visibility and only what the public headers mark IMM_RUNTIME_EXPORT leaves it. No symbol of an
# internal namespace (detail, the container's internals, an anonymous namespace) and no pimpl
# (Impl) may be in its dynamic symbol table, and the API's entry points must be.
#
#   cmake -DLIBRARY=<libimmruntime.so> -P check_exports.cmake
find_program(NM nm REQUIRED)
execute_process(COMMAND ${NM} -D --defined-only -C ${LIBRARY} OUTPUT_VARIABLE symbols
                RESULT_VARIABLE status)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "nm failed on ${LIBRARY}")
endif()
string(REGEX MATCHALL "[^\n]*imm::[^\n]*" ours "${symbols}")
set(leaks "")
foreach(symbol ${ours})
  if(symbol MATCHES "imm::[A-Za-z_:]*(detail|container)::|::Impl|anonymous namespace")
    string(APPEND leaks "  ${symbol}\n")
  endif()
endforeach()
if(leaks)
  message(FATAL_ERROR "internal symbols exported by the runtime:\n${leaks}")
endif()
# UBSan's function check (-fsanitize=function) gives every function type it checks a typeinfo
# ("typeinfo for R (Args...)"), exported with the function: 150 in the sanitizer build. They are
# not the library's API and are left out of the count.
set(counted ${ours})
list(FILTER counted EXCLUDE REGEX "typeinfo (name )?for [^(]*\\(")
list(LENGTH counted count)
message(STATUS "${LIBRARY}: ${count} exported symbols of namespace imm")
foreach(api "imm::load_filter(" "imm::io::ModelFileReader::ModelFileReader("
            "imm::Tracker::process(" "typeinfo for imm::InvalidParameter" "typeinfo for imm::io::FileError")
  string(FIND "${symbols}" "${api}" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "the runtime does not export ${api}: is IMM_RUNTIME_EXPORT defined empty?")
  endif()
endforeach()
# Hidden by default: the same sources built with default visibility (CXX_VISIBILITY_PRESET default,
# VISIBILITY_INLINES_HIDDEN off) export 4698 symbols of namespace imm (every inline function and
# template instance the library compiles), the API 458 (483 in the sanitizer build: its
# instrumented inline functions and vtables). The bound sits between, with room for the API to
# grow: a count near it is a reason to look at what the API exports, not to raise it blindly.
if(count GREATER 600)
  message(FATAL_ERROR "${count} exported symbols: is the runtime built with hidden visibility?")
endif()
