// SPDX-License-Identifier: Apache-2.0
#pragma once
// What a study's main() does around its work: the exit code of run(argc, argv), or 1 after one
// line "<tool>: <what went wrong>" on stderr when it throws.

#include <exception>
#include <iostream>

namespace imm::studies {

inline int study_main(const char* tool, int (*run)(int, char**), int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& error) {
    std::cerr << tool << ": " << error.what() << '\n';
    return 1;
  }
}

}  // namespace imm::studies
