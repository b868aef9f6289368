# SPDX-License-Identifier: Apache-2.0
# imm_target_warnings(<target>): the project's warning set, applied to its own targets only.
function(imm_target_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor
                                           -Wold-style-cast -Wcast-align -Woverloaded-virtual)
endfunction()
