// SPDX-License-Identifier: Apache-2.0
#include "imm/io/plain_imm_file.hpp"

#include "imm/core/invalid_parameter.hpp"
#include "imm/io/ga_fuzzy_imm_file.hpp"

namespace imm::io {
namespace {
std::string mode_group(std::size_t index) { return "/imm/modes/mode" + std::to_string(index); }

// Maps a spec field ("modes[1].tau") to the model-file field that holds it.
std::string file_field(const std::string& spec_field) {
  if (spec_field.rfind("modes[", 0) == 0) {
    const std::size_t close = spec_field.find(']');
    const std::string index = spec_field.substr(6, close - 6);
    const std::string key = close + 2 <= spec_field.size() ? spec_field.substr(close + 2) : "";
    return "/imm/modes/mode" + index + (key.empty() ? "" : "@" + key);
  }
  if (spec_field == "transition") return "/imm/transition";
  if (spec_field == "initial_probabilities") return "/imm/initial_probabilities";
  if (spec_field == "sample_period") return "/imm@sample_period";
  if (spec_field.rfind("measurement.", 0) == 0) return "/measurement/covariance";
  if (spec_field.rfind("initialization.", 0) == 0) {
    const std::string key = spec_field.substr(15);
    // The state and its covariance are datasets; the variances attributes.
    return key == "state" || key == "covariance" ? "/initialization/" + key
                                                 : "/initialization@" + key;
  }
  return "/" + spec_field;
}
}  // namespace

void write_plain_imm(ModelFileWriter& writer, const PlainImmSpec& spec) {
  spec.validate();
  const UnitNames& u = writer.units();
  writer.set_quantity("/imm", "sample_period", spec.sample_period, "s");
  writer.set_attribute("/imm", "mode_count", static_cast<std::int64_t>(spec.modes.size()));
  std::vector<std::string> mode_names;
  for (const ModeSpec& mode : spec.modes) mode_names.push_back(mode.name);
  writer.write_matrix("/imm/transition", spec.transition, mode_names, kDimensionless);
  writer.write_vector("/imm/initial_probabilities", spec.initial_probabilities, kDimensionless);
  for (std::size_t i = 0; i < spec.modes.size(); ++i) {
    const ModeSpec& mode = spec.modes[i];
    const std::string group = mode_group(i);
    writer.set_attribute(group, "name", mode.name);
    writer.set_attribute(group, "motion", std::string(to_string(mode.motion)));
    writer.set_attribute(group, "noise_form", std::string(to_string(mode.noise_form)));
    // q: the variance of the highest derivative's per-period value (piecewise), or the power
    // spectral density of its continuous white noise (continuous): of the acceleration for CV,
    // of the jerk for CA.
    std::string q_units = mode.noise_form == NoiseForm::kPiecewiseConstant
                              ? u.acceleration_variance()
                              : u.acceleration_density();
    if (mode.motion == MotionKind::kConstantAcceleration &&
        mode.noise_form == NoiseForm::kContinuous) {
      q_units = u.length + "^2/s^5";
    }
    writer.set_quantity(group, "process_noise", mode.process_noise, q_units);
    if (mode.motion == MotionKind::kCoordinatedTurn) {
      // ω's noise in the same form: rad²/s⁴ per period, or the PSD in rad²/s³.
      writer.set_quantity(
          group, "turn_noise", mode.turn_noise,
          mode.noise_form == NoiseForm::kPiecewiseConstant ? "rad^2/s^4" : "rad^2/s^3");
    }
    writer.set_quantity(group, "tau", mode.singer_tau, "s");
    writer.set_quantity(group, "sigma_a", mode.singer_sigma, u.acceleration());
    if (mode.noise_schedule) {
      // A reader of version 2 would ignore the table and run the fixed Q: version 3.
      writer.require_schema_version(3);
      writer.set_attribute(group, "noise_schedule_rules",
                           static_cast<std::int64_t>(mode.noise_schedule->size()));
      writer.write_matrix(group + "/noise_schedule", rules_matrix(*mode.noise_schedule),
                          {"c1", "sigma1", "c2", "sigma2", "w"}, "1,1,1,1,1");
    }
  }
  writer.set_attribute("/measurement", "kind", std::string(to_string(spec.measurement.kind)));
  if (spec.measurement.kind == MeasurementKind::kPolar) {
    writer.write_covariance("/measurement/covariance", spec.measurement.covariance,
                            {"range", "azimuth"}, u.length + ",rad");
  } else {
    writer.write_covariance("/measurement/covariance", spec.measurement.covariance, {"x", "y"},
                            u.length + "," + u.length);
  }
  writer.set_attribute("/initialization", "method",
                       std::string(to_string(spec.initialization.method)));
  writer.set_quantity("/initialization", "acceleration_variance",
                      spec.initialization.acceleration_variance, u.acceleration_variance());
  if (spec.has_turn_rate()) {
    writer.set_quantity("/initialization", "turn_rate_variance",
                        spec.initialization.turn_rate_variance, "rad^2/s^2");
  }
  if (spec.initialization.method == InitializationMethod::kExplicit) {
    std::vector<std::string> variables = {"x", "vx", "y", "vy"};
    std::string units = u.length + "," + u.speed() + "," + u.length + "," + u.speed();
    if (spec.mixing_dimension() >= 6) {
      variables = {"x", "vx", "ax", "y", "vy", "ay"};
      units = u.length + "," + u.speed() + "," + u.acceleration() + "," + u.length + "," +
              u.speed() + "," + u.acceleration();
    }
    if (spec.has_turn_rate()) {
      variables.emplace_back("omega");
      units += ",rad/s";
    }
    writer.write_vector("/initialization/state", spec.initialization.state, units);
    writer.write_covariance("/initialization/covariance", spec.initialization.covariance, variables,
                            units);
  }
}

PlainImmSpec read_plain_imm(const ModelFileReader& reader) {
  PlainImmSpec spec;
  spec.sample_period = reader.real("/imm", "sample_period", ValueRule::kPositive);
  const auto n = static_cast<int>(reader.integer("/imm", "mode_count", 1, kMaxModes));
  spec.transition = reader.matrix("/imm/transition", n, n, ValueRule::kProbability);
  spec.initial_probabilities =
      reader.vector("/imm/initial_probabilities", n, ValueRule::kProbability);
  for (int i = 0; i < n; ++i) {
    const std::string group = mode_group(static_cast<std::size_t>(i));
    ModeSpec mode;
    mode.name = reader.text(group, "name");
    try {
      mode.motion = motion_kind_from(reader.text(group, "motion"), "motion");
      mode.noise_form = noise_form_from(reader.text(group, "noise_form"), "noise_form");
    } catch (const InvalidParameter& error) {
      reader.fail(group + "@" + error.field(), error.what());
    }
    mode.process_noise = reader.real(group, "process_noise", ValueRule::kNonNegative);
    if (mode.motion == MotionKind::kCoordinatedTurn) {
      mode.turn_noise = reader.real(group, "turn_noise", ValueRule::kNonNegative);
    }
    mode.singer_tau = reader.real(group, "tau", ValueRule::kPositive);
    mode.singer_sigma = reader.real(group, "sigma_a", ValueRule::kNonNegative);
    if (reader.container().attribute(group, "noise_schedule_rules")) {
      if (reader.schema_version() < 3) {
        reader.fail(group + "@noise_schedule_rules", "needs schema version 3");
      }
      const auto rules = reader.integer(group, "noise_schedule_rules", 1,
                                        static_cast<std::int64_t>(FuzzyRuleTable::kMaxRules));
      const std::string dataset = group + "/noise_schedule";
      try {
        mode.noise_schedule = table_from_matrix(reader.matrix(dataset, static_cast<int>(rules), 5));
      } catch (const std::invalid_argument& error) {
        reader.fail(dataset, error.what());
      }
    }
    spec.modes.push_back(std::move(mode));
  }
  try {
    spec.measurement.kind = measurement_kind_from(reader.text("/measurement", "kind"), "kind");
    spec.initialization.method =
        initialization_method_from(reader.text("/initialization", "method"), "method");
  } catch (const InvalidParameter& error) {
    reader.fail(error.field() == "kind" ? "/measurement@kind" : "/initialization@method",
                error.what());
  }
  spec.measurement.covariance = reader.matrix("/measurement/covariance", 2, 2);
  spec.initialization.acceleration_variance =
      reader.real("/initialization", "acceleration_variance", ValueRule::kNonNegative);
  if (spec.has_turn_rate()) {
    spec.initialization.turn_rate_variance =
        reader.real("/initialization", "turn_rate_variance", ValueRule::kNonNegative);
  }
  if (spec.initialization.method == InitializationMethod::kExplicit) {
    const int nx = spec.mixing_dimension();
    spec.initialization.state = reader.vector("/initialization/state", nx);
    spec.initialization.covariance = reader.matrix("/initialization/covariance", nx, nx);
  }
  try {
    spec.validate();
  } catch (const InvalidParameter& error) {
    reader.fail(file_field(error.field()), error.what());
  }
  reader.require_units_of_reals();
  return spec;
}

PlainImmSpec read_plain_imm(const std::filesystem::path& path) {
  return read_plain_imm(ModelFileReader(path, kPlainImmKind));
}

}  // namespace imm::io
