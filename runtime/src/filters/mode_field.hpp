// SPDX-License-Identifier: Apache-2.0
#pragma once
// A plain IMM's mode field as the configs spell it in errors ("modes[1].process_noise",
// imm/core/invalid_parameter.hpp): one wording for PlainImmSpec::validate and the banks that refuse
// a spec. Not installed.

#include <cstddef>
#include <string>

namespace imm::detail {

[[nodiscard]] inline std::string mode_field(std::size_t index, const char* key) {
  return "modes[" + std::to_string(index) + "]." + key;
}

}  // namespace imm::detail
