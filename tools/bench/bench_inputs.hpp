// SPDX-License-Identifier: Apache-2.0
#pragma once
// The inputs the benchmarks share: paper-preset tracks and the W1 workload.

#include <Eigen/Core>
#include <string>

#include "imm/datasets/regime_file.hpp"
#include "imm/datasets/track.hpp"
#include "workloads.hpp"

namespace imm::bench {

// Test track `index` (seed 1) of a paper preset (configs/regimes/paper/NAME.toml); a scripted
// regime's track i follows its case i mod cases.
inline imm::datasets::Track preset_track(const std::string& name, int index = 0) {
  const auto file = imm::datasets::load_regime(
      std::string(IMM_SOURCE_DIR "/configs/regimes/paper/") + name + ".toml");
  return imm::datasets::draw_track(file.regime, imm::datasets::Split::kTest, index, 1);
}

/// The sample period of a paper preset's regime.
inline double preset_sample_period(const std::string& name) {
  return imm::datasets::load_regime(std::string(IMM_SOURCE_DIR "/configs/regimes/paper/") + name +
                                    ".toml")
      .regime.sample_period;
}

inline const Eigen::MatrixXd& table3_plots() {
  static const Eigen::MatrixXd plots = preset_track("ga_imm_table3").plots;
  return plots;
}

// The W1 workload's plots and truth (tools/workloads/inputs).
inline const imm::workloads::W1Input& w1_input() {
  static const imm::workloads::W1Input input =
      imm::workloads::load_w1(imm::workloads::input_folder());
  return input;
}

}  // namespace imm::bench
