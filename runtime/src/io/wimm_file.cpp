// SPDX-License-Identifier: Apache-2.0
#include "imm/io/wimm_file.hpp"

#include "imm/core/invalid_parameter.hpp"

namespace imm::io {
namespace {
constexpr const char* kWimmGroup = "/wimm";
}

void write_wimm(ModelFileWriter& writer, const WimmSpec& spec) {
  spec.validate();
  const UnitNames& u = writer.units();
  writer.set_quantity(kWimmGroup, "sample_period", spec.sample_period, "s");
  writer.set_quantity(kWimmGroup, "cv_process_noise", spec.cv_process_noise,
                      u.acceleration_variance());
  writer.set_quantity(kWimmGroup, "singer_tau", spec.singer_tau, "s");
  writer.set_quantity(kWimmGroup, "singer_sigma", spec.singer_sigma, u.acceleration());
  writer.set_quantity(kWimmGroup, "range_sigma", spec.range_sigma, u.length);
  writer.set_quantity(kWimmGroup, "azimuth_sigma", spec.azimuth_sigma, "rad");
  writer.set_quantity(kWimmGroup, "threshold", spec.threshold, kDimensionless);
  writer.set_quantity(kWimmGroup, "alpha", spec.alpha, kDimensionless);
  writer.set_attribute(kWimmGroup, "fusion", std::string(to_string(spec.fusion)));
  writer.set_attribute(kWimmGroup, "update", std::string(to_string(spec.update)));
  writer.set_quantity(kWimmGroup, "acceleration_variance", spec.acceleration_variance,
                      u.acceleration_variance());
  writer.write_matrix("/wimm/transition", spec.transition, {"cv", "singer"}, kDimensionless);
  writer.write_vector("/wimm/initial_probabilities", spec.initial_probabilities, kDimensionless);
}

WimmSpec read_wimm(const ModelFileReader& reader) {
  WimmSpec spec;
  spec.sample_period = reader.real(kWimmGroup, "sample_period", ValueRule::kPositive);
  spec.cv_process_noise = reader.real(kWimmGroup, "cv_process_noise", ValueRule::kNonNegative);
  spec.singer_tau = reader.real(kWimmGroup, "singer_tau", ValueRule::kPositive);
  spec.singer_sigma = reader.real(kWimmGroup, "singer_sigma", ValueRule::kNonNegative);
  spec.range_sigma = reader.real(kWimmGroup, "range_sigma", ValueRule::kPositive);
  spec.azimuth_sigma = reader.real(kWimmGroup, "azimuth_sigma", ValueRule::kPositive);
  spec.threshold = reader.real(kWimmGroup, "threshold");
  spec.alpha = reader.real(kWimmGroup, "alpha", ValueRule::kProbability);
  spec.acceleration_variance =
      reader.real(kWimmGroup, "acceleration_variance", ValueRule::kNonNegative);
  try {
    spec.fusion = fusion_variant_from(reader.text(kWimmGroup, "fusion"), "fusion");
    spec.update = measurement_update_from(reader.text(kWimmGroup, "update"), "update");
  } catch (const InvalidParameter& error) {
    reader.fail(std::string(kWimmGroup) + "@" + error.field(), error.what());
  }
  spec.transition = reader.matrix("/wimm/transition", 2, 2, ValueRule::kProbability);
  spec.initial_probabilities =
      reader.vector("/wimm/initial_probabilities", 2, ValueRule::kProbability);
  try {
    spec.validate();
  } catch (const InvalidParameter& error) {
    reader.fail_spec(kWimmGroup, error, {"transition", "initial_probabilities"});
  }
  reader.require_units_of_reals();
  return spec;
}

WimmSpec read_wimm(const std::filesystem::path& path) {
  return read_wimm(ModelFileReader(path, kWimmKind));
}

}  // namespace imm::io
