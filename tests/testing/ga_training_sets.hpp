// SPDX-License-Identifier: Apache-2.0
#pragma once
// The GA trainer's training data of small test regimes (tests that link imm::trainer).

#include <filesystem>

#include "imm/datasets/regime_file.hpp"
#include "imm/trainer/training_set.hpp"
#include "testing/regime_files.hpp"
#include "testing/temp_dir.hpp"

namespace imm::testing {

// The one-axis trajectories of the training split of the regime file `regime`.
inline trainer::TrainingSet training_split(const std::filesystem::path& regime) {
  return trainer::make_training_set(datasets::load_regime(regime).regime,
                                    datasets::Split::kTraining);
}

// The training split of write_ga_regime(dir, scans, training, validation), written and read in a
// folder of its own.
inline trainer::TrainingSet ga_training_set(int scans, int training, int validation) {
  const TempDir dir;
  return training_split(write_ga_regime(dir, scans, training, validation));
}

}  // namespace imm::testing
