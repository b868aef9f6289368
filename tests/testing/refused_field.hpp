// SPDX-License-Identifier: Apache-2.0
#pragma once
// The field an InvalidParameter names, for tests of what a call refuses.

#include <string>

#include "imm/core/invalid_parameter.hpp"

namespace imm::testing {

// The field of the InvalidParameter that `call()` throws; "" when it throws none.
template <class Call>
std::string refused_field_of(Call&& call) {
  try {
    call();
  } catch (const InvalidParameter& error) {
    return error.field();
  }
  return "";
}

}  // namespace imm::testing
