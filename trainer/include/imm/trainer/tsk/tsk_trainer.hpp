// SPDX-License-Identifier: Apache-2.0
#pragma once
/// `imm-train tsk --config configs/tsk_range_sensor.toml`: the probabilistic TSK model of a
/// distorted range sensor (seed 002 §2.2, §3.3). The sensor is the regime's range sensor: its
/// calibration data are drawn from it ([sensor.calibration]: 8000 obstacle positions and their
/// distorted, noisy outputs), or — for a sensor known through samples — are those samples. A
/// validation split is held out, each output fitted (tsk_fit.hpp: FCRM with restarts, premises
/// from the clusters, Ceres fine tuning, σ by eq. 7), the validation RMSE reported after FCRM and
/// after fine tuning, and a "tsk_sensor" model written with the input box it was trained on, the
/// data's digest and the regime.
///
/// The config also carries what the evaluation needs and the trainer does not: the FIMM settings
/// ([fimm]; T is the regime's); they are validated here all the same.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

#include "imm/datasets/range_sensor.hpp"
#include "imm/datasets/regime.hpp"
#include "imm/filters/fimm.hpp"
#include "imm/trainer/mode_sojourns.hpp"
#include "imm/trainer/tsk/tsk_fit.hpp"

namespace imm::trainer::tsk {

struct TskTrainingConfig {
  std::uint64_t seed = 1;
  datasets::Regime regime;  ///< its sensor is a range sensor
  double validation_fraction = 0.2;
  FcrmSettings fcrm;
  TNorm t_norm = TNorm::kMin;
  FineTuning fine_tuning;
  double max_validation_rmse = 0.5;  ///< gate, per output (m)

  FimmSpec fimm;            ///< for imm-eval fimm (T from the regime, R per case)
  int iekf_iterations = 5;  ///< the FIMM (IEKF) variant
  /// `fimm.transition = "sojourns"`: the FIMM's mode transitions are learned from the regime's
  /// training tracks (cruise / lane change, from the truth's maneuver labels) as a continuous-time
  /// chain (mode_sojourns.hpp) and discretized at the regime's T; otherwise `fimm.transition` is
  /// the config's matrix (the seed preset's).
  bool transitions_from_sojourns = false;

  std::string text, name;

  void validate() const;  ///< InvalidParameter naming the key
};

[[nodiscard]] TskTrainingConfig load_tsk_config(
    const std::filesystem::path& path,
    const std::optional<std::filesystem::path>& regime = std::nullopt);

struct OutputReport {
  double fcrm_training_rmse = 0.0, fcrm_validation_rmse = 0.0;
  double training_rmse = 0.0, validation_rmse = 0.0;  ///< after fine tuning
  double sigma = 0.0;
  double fcrm_objective = 0.0;
  int fcrm_iterations = 0;
  FineTuningReport fine_tuning;
};

struct TskTrainingResult {
  TskSensorModel model;
  /// The FIMM written beside the sensor model (its transition learned when the config says so).
  FimmSpec fimm;
  /// The mean sojourns behind a learned transition (empty otherwise).
  std::optional<SojournEstimate> sojourns;
  OutputReport outputs[2];
  int training_samples = 0, validation_samples = 0;
  double wall_seconds = 0.0;
  bool gate_passed = false;
  std::string digest;
};

/// The split of a data set: the first (1 − fraction) of a seeded permutation trains.
struct SplitData {
  Eigen::MatrixXd training_inputs, validation_inputs;
  Eigen::MatrixXd training_outputs, validation_outputs;
};
[[nodiscard]] SplitData split(const datasets::RangeSensorData& data, double validation_fraction,
                              std::uint64_t seed);

/// Sensor samples to fit on, and where they came from (for the metrics).
struct SensorSamples {
  datasets::RangeSensorData data;
  std::string source;
};

/// Stored samples: a "range_sensor" data set (.h5, digest checked) or a CSV with the header
/// xi,eta,z1,z2 (true position, sensor output; '#' lines are comments). FileError names the
/// file and, for a CSV, the line. They must be the samples of the config's regime (a sensor known
/// through samples with the same digest): the evaluation then runs the sensor the model was
/// fitted to. InvalidParameter ("regime") otherwise.
[[nodiscard]] SensorSamples load_sensor_samples(const std::filesystem::path& path,
                                                const TskTrainingConfig& config);
/// The regime's calibration data: drawn from its sensor, or its sensor's samples.
[[nodiscard]] SensorSamples calibration_samples(const TskTrainingConfig& config);

/// Fits both outputs on the regime's calibration data; writes the model (gate passed) and
/// `<model>.metrics.json` (always).
TskTrainingResult train_tsk(const TskTrainingConfig& config, const std::filesystem::path& out);
/// The same on given samples. The model's input box is the samples' extent.
TskTrainingResult train_tsk(const TskTrainingConfig& config, const SensorSamples& samples,
                            const std::filesystem::path& out);

}  // namespace imm::trainer::tsk
