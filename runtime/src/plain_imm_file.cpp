// SPDX-License-Identifier: Apache-2.0
#include "imm/io/plain_imm_file.hpp"

#include "imm/core/invalid_parameter.hpp"

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
    return "/initialization/" + spec_field.substr(15);
  }
  return "/" + spec_field;
}
}  // namespace

void write_plain_imm(ModelFileWriter& writer, const PlainImmSpec& spec) {
  spec.validate();
  writer.set_attribute("/imm", "sample_period", spec.sample_period);
  writer.set_attribute("/imm", "mode_count", static_cast<std::int64_t>(spec.modes.size()));
  writer.write_matrix("/imm/transition", spec.transition);
  writer.write_vector("/imm/initial_probabilities", spec.initial_probabilities);
  for (std::size_t i = 0; i < spec.modes.size(); ++i) {
    const ModeSpec& mode = spec.modes[i];
    const std::string group = mode_group(i);
    writer.set_attribute(group, "name", mode.name);
    writer.set_attribute(group, "motion", std::string(to_string(mode.motion)));
    writer.set_attribute(group, "noise_form", std::string(to_string(mode.noise_form)));
    writer.set_attribute(group, "process_noise", mode.process_noise);
    writer.set_attribute(group, "tau", mode.singer_tau);
    writer.set_attribute(group, "sigma_a", mode.singer_sigma);
  }
  writer.set_attribute("/measurement", "kind", std::string(to_string(spec.measurement.kind)));
  writer.write_matrix("/measurement/covariance", spec.measurement.covariance);
  writer.set_attribute("/initialization", "method",
                       std::string(to_string(spec.initialization.method)));
  writer.set_attribute("/initialization", "acceleration_variance",
                       spec.initialization.acceleration_variance);
  if (spec.initialization.method == InitializationMethod::kExplicit) {
    writer.write_vector("/initialization/state", spec.initialization.state);
    writer.write_matrix("/initialization/covariance", spec.initialization.covariance);
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
    mode.singer_tau = reader.real(group, "tau", ValueRule::kPositive);
    mode.singer_sigma = reader.real(group, "sigma_a", ValueRule::kNonNegative);
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
  return spec;
}

PlainImmSpec read_plain_imm(const std::filesystem::path& path) {
  return read_plain_imm(ModelFileReader(path, kPlainImmKind));
}

}  // namespace imm::io
