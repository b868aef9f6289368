// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/model_files/freeze.hpp"

#include <chrono>
#include <cmath>

#include "imm/datasets/regime_file.hpp"
#include "imm/io/plain_imm_file.hpp"
#include "imm/support/plain_imm_config.hpp"
#include "imm/trainer/model_files/write_model.hpp"
#include "imm/trainer/provenance.hpp"

namespace imm::trainer {

FreezeSummary freeze_plain_imm(const FreezeOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const support::PlainImmConfig config = support::load_plain_imm_file(options.config);
  const PlainImmSpec& spec = config.spec;
  io::Provenance provenance =
      make_provenance(std::string(io::kPlainImmKind), read_text_file(options.config), 0, "");
  provenance.length_unit = config.length_unit;
  if (options.regime) {
    const datasets::Regime regime = datasets::load_regime(*options.regime).regime;
    const std::string file = options.config.string();
    if (std::abs(spec.sample_period - regime.sample_period) > 1e-12 * regime.sample_period) {
      throw support::ConfigError(file, "sample_period",
                                 "differs from regime '" + regime.name + "' (" +
                                     std::to_string(regime.sample_period) + " s)");
    }
    const bool polar = regime.sensor.kind == datasets::SensorKind::kPolar;
    if (regime.sensor.kind == datasets::SensorKind::kRangeSensor ||
        (spec.measurement.kind == MeasurementKind::kPolar) != polar) {
      throw support::ConfigError(file, "measurement.kind",
                                 "does not fit regime '" + regime.name + "' (a " +
                                     std::string(datasets::to_string(regime.sensor.kind)) +
                                     " sensor)");
    }
    for (int c = 0; c < regime.case_count(); ++c) {
      if (!spec.measurement.covariance.isApprox(regime.noise_of(c).covariance(), 1e-9)) {
        throw support::ConfigError(file, "measurement.covariance",
                                   "differs from the plot noise of regime '" + regime.name + "'");
      }
    }
    if (config.length_unit != datasets::to_string(regime.units)) {
      throw support::ConfigError(file, "units",
                                 "\"" + config.length_unit + "\" differs from regime '" +
                                     regime.name + "' (" +
                                     std::string(datasets::to_string(regime.units)) + ")");
    }
    set_regime(provenance, regime);
  }
  write_model_file(options.out, provenance,
                   [&](io::ModelFileWriter& writer) { io::write_plain_imm(writer, spec); });

  FreezeSummary summary;
  summary.modes = static_cast<int>(spec.modes.size());
  summary.state_dimension = spec.mixing_dimension();
  summary.wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  nlohmann::json metrics = metrics_of(io::kPlainImmKind, options.out, options.config.string());
  metrics["modes"] = summary.modes;
  metrics["state_dimension"] = summary.state_dimension;
  metrics["wall_seconds"] = summary.wall_seconds;
  write_json_atomically(metrics_path(options.out), metrics);
  return summary;
}

}  // namespace imm::trainer
