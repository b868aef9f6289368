// SPDX-License-Identifier: Apache-2.0
#include "imm/io/wimm_file.hpp"

#include "imm/core/invalid_parameter.hpp"

namespace imm::io {
namespace {
constexpr const char* kGroup = "/wimm";
}

void write_wimm(ModelFileWriter& writer, const WimmSpec& spec) {
  spec.validate();
  const UnitNames& u = writer.units();
  writer.set_quantity(kGroup, "sample_period", spec.sample_period, "s");
  writer.set_quantity(kGroup, "cv_process_noise", spec.cv_process_noise, u.acceleration_variance());
  writer.set_quantity(kGroup, "singer_tau", spec.singer_tau, "s");
  writer.set_quantity(kGroup, "singer_sigma", spec.singer_sigma, u.acceleration());
  writer.set_quantity(kGroup, "range_sigma", spec.range_sigma, u.length);
  writer.set_quantity(kGroup, "azimuth_sigma", spec.azimuth_sigma, "rad");
  writer.set_quantity(kGroup, "threshold", spec.threshold, kDimensionless);
  writer.set_quantity(kGroup, "alpha", spec.alpha, kDimensionless);
  writer.set_attribute(kGroup, "fusion", std::string(to_string(spec.fusion)));
  writer.set_attribute(kGroup, "update", std::string(to_string(spec.update)));
  writer.set_quantity(kGroup, "acceleration_variance", spec.acceleration_variance,
                      u.acceleration_variance());
  writer.write_matrix("/wimm/transition", spec.transition, {"cv", "singer"}, kDimensionless);
  writer.write_vector("/wimm/initial_probabilities", spec.initial_probabilities, kDimensionless);
}

WimmSpec read_wimm(const ModelFileReader& reader) {
  WimmSpec spec;
  spec.sample_period = reader.real(kGroup, "sample_period", ValueRule::kPositive);
  spec.cv_process_noise = reader.real(kGroup, "cv_process_noise", ValueRule::kNonNegative);
  spec.singer_tau = reader.real(kGroup, "singer_tau", ValueRule::kPositive);
  spec.singer_sigma = reader.real(kGroup, "singer_sigma", ValueRule::kNonNegative);
  spec.range_sigma = reader.real(kGroup, "range_sigma", ValueRule::kPositive);
  spec.azimuth_sigma = reader.real(kGroup, "azimuth_sigma", ValueRule::kPositive);
  spec.threshold = reader.real(kGroup, "threshold");
  spec.alpha = reader.real(kGroup, "alpha", ValueRule::kProbability);
  spec.acceleration_variance =
      reader.real(kGroup, "acceleration_variance", ValueRule::kNonNegative);
  try {
    spec.fusion = fusion_variant_from(reader.text(kGroup, "fusion"), "fusion");
    spec.update = measurement_update_from(reader.text(kGroup, "update"), "update");
  } catch (const InvalidParameter& error) {
    reader.fail(std::string(kGroup) + "@" + error.field(), error.what());
  }
  spec.transition = reader.matrix("/wimm/transition", 2, 2, ValueRule::kProbability);
  spec.initial_probabilities =
      reader.vector("/wimm/initial_probabilities", 2, ValueRule::kProbability);
  try {
    spec.validate();
  } catch (const InvalidParameter& error) {
    reader.fail_spec(kGroup, error, {"transition", "initial_probabilities"});
  }
  reader.require_units_of_reals();
  return spec;
}

WimmSpec read_wimm(const std::filesystem::path& path) {
  return read_wimm(ModelFileReader(path, kWimmKind));
}

}  // namespace imm::io
