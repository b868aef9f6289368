// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Long-run tests at two lengths: the default suite runs the shortest length that still fails
/// when the behaviour breaks, and `make test-long` runs the same test as a study (ctest label
/// `long`, IMM_TEST_STUDY=1; tests/CMakeLists.txt, imm_add_study).

#include <cstdlib>
#include <string_view>

namespace imm::testing {

/// True when the test runs as a study (make test-long).
inline bool running_as_study() {
  const char* value = std::getenv("IMM_TEST_STUDY");
  return value != nullptr && std::string_view(value) == "1";
}

/// True in a build with AddressSanitizer (make test-sanitize), where every instruction costs
/// several times its Release time.
constexpr bool running_sanitized() {
#if defined(__SANITIZE_ADDRESS__)
  return true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
  return true;
#else
  return false;
#endif
#else
  return false;
#endif
}

/// `quick` in the default suite, `study` under make test-long.
template <class T>
T quick_or_study(T quick, T study) {
  return running_as_study() ? study : quick;
}

}  // namespace imm::testing
