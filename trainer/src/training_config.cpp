// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/training_config.hpp"

namespace imm::trainer {

datasets::RegimeFile regime_of(const support::ConfigTable& root,
                               const std::optional<std::filesystem::path>& override) {
  const std::string named = root.text_or("regime", "");
  if (!override && named.empty()) root.fail("regime", "missing: name the regime file to train for");
  datasets::RegimeFile file =
      datasets::load_regime(override ? *override : std::filesystem::path(named));
  return file;
}

}  // namespace imm::trainer
