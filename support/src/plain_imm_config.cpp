// SPDX-License-Identifier: Apache-2.0
#include "imm/support/plain_imm_config.hpp"

#include "imm/core/invalid_parameter.hpp"
#include "imm/io/model_file.hpp"

namespace imm::support {
namespace {

// Converts the name-to-enum errors of the runtime into ConfigErrors on the right key.
template <class Parse>
auto parse_name(const ConfigTable& table, std::string_view key, Parse&& parse) {
  const std::string name = table.text(key);
  try {
    return parse(name, table.path(key));
  } catch (const InvalidParameter& error) {
    table.fail(key, error.message());
  }
}

}  // namespace

PlainImmSpec plain_imm_from(const ConfigTable& table) {
  PlainImmSpec spec;
  spec.sample_period = table.real("sample_period");
  for (const ConfigTable& mode_table : table.tables("modes")) {
    ModeSpec mode;
    mode.name = mode_table.text("name");
    mode.motion = parse_name(mode_table, "motion", motion_kind_from);
    if (mode.motion == MotionKind::kSinger) {
      mode.singer_tau = mode_table.real("tau");
      mode.singer_sigma = mode_table.real("sigma_a");
    } else {
      mode.process_noise = mode_table.real("process_noise");
      if (mode_table.has("noise_form")) {
        mode.noise_form = parse_name(mode_table, "noise_form", noise_form_from);
      }
      if (mode.motion == MotionKind::kCoordinatedTurn)
        mode.turn_noise = mode_table.real("turn_noise");
    }
    spec.modes.push_back(std::move(mode));
  }
  if (spec.modes.empty()) table.fail("modes", "at least one [[modes]] table is required");
  const auto n = static_cast<long>(spec.modes.size());
  spec.transition = table.matrix("transition", n, n);
  spec.initial_probabilities = table.reals("initial_probabilities", n);

  const auto measurement = table.table("measurement");
  if (!measurement) table.fail("measurement", "missing");
  spec.measurement.kind = parse_name(*measurement, "kind", measurement_kind_from);
  const bool has_covariance = measurement->has("covariance");
  if (has_covariance == measurement->has("sigma")) {
    measurement->fail("covariance", "give exactly one of covariance or sigma");
  }
  spec.measurement.covariance =
      has_covariance ? Eigen::Matrix2d(measurement->matrix("covariance", 2, 2))
                     : Eigen::Matrix2d(measurement->reals("sigma", 2).cwiseAbs2().asDiagonal());

  if (const auto init = table.table("initialization")) {
    spec.initialization.method = parse_name(*init, "method", initialization_method_from);
    spec.initialization.acceleration_variance = init->real_or("acceleration_variance", 0.0);
    spec.initialization.turn_rate_variance = init->real_or("turn_rate_variance", 0.0);
    if (spec.initialization.method == InitializationMethod::kExplicit) {
      spec.initialization.state = init->reals("state");
      spec.initialization.covariance = init->matrix("covariance");
    }
  }
  spec.validate();
  return spec;
}

PlainImmConfig load_plain_imm_file(const std::filesystem::path& path) {
  const auto document = ConfigDocument::load(path);
  return document->load_checked([&] {
    PlainImmConfig config;
    const ConfigTable& root = document->root();
    config.length_unit = root.text_or("units", "m");
    if (!io::valid_length_unit(config.length_unit)) {
      root.fail("units", "must be \"m\" or \"km\"");
    }
    config.spec = plain_imm_from(root);
    return config;
  });
}

PlainImmSpec load_plain_imm_config(const std::filesystem::path& path) {
  return load_plain_imm_file(path).spec;
}

}  // namespace imm::support
