// SPDX-License-Identifier: Apache-2.0
#include "imm/io/fcm_imm_file.hpp"

#include "imm/core/invalid_parameter.hpp"

namespace imm::io {
namespace {
constexpr const char* kFcmImmGroup = "/fcm_imm";
}

void write_fcm_imm(ModelFileWriter& writer, const FcmImmSpec& spec) {
  spec.validate();
  if (spec.mean_memberships.size() == 0) {
    throw InvalidParameter("mean_memberships", "a model file needs the mean memberships");
  }
  const UnitNames& u = writer.units();
  writer.set_quantity(kFcmImmGroup, "sample_period", spec.sample_period, "s");
  writer.set_quantity(kFcmImmGroup, "measurement_sigma", spec.measurement_sigma, u.length);
  writer.set_attribute(kFcmImmGroup, "window", static_cast<std::int64_t>(spec.window));
  writer.set_quantity(kFcmImmGroup, "fuzzifier", spec.clustering.fuzzifier, kDimensionless);
  writer.set_quantity(kFcmImmGroup, "tolerance", spec.clustering.tolerance, kDimensionless);
  writer.set_attribute(kFcmImmGroup, "max_iterations",
                       static_cast<std::int64_t>(spec.clustering.max_iterations));
  writer.set_attribute(kFcmImmGroup, "membership_scale", std::string(to_string(spec.scale)));
  writer.set_quantity(kFcmImmGroup, "separation", spec.separation, kDimensionless);
  writer.set_quantity(kFcmImmGroup, "compensation_gain", spec.compensation_gain, kDimensionless);
  writer.set_attribute(kFcmImmGroup, "compensate_lowest",
                       static_cast<std::int64_t>(spec.compensate_lowest ? 1 : 0));
  const Eigen::Map<const Eigen::VectorXd> q(spec.process_noise.data(),
                                            static_cast<Eigen::Index>(spec.process_noise.size()));
  writer.write_vector("/fcm_imm/process_noise", q, u.acceleration_variance());
  std::vector<std::string> modes;
  for (int j = 0; j < spec.mode_count(); ++j) modes.push_back("mode" + std::to_string(j));
  writer.write_matrix("/fcm_imm/transition", spec.transition, modes, kDimensionless);
  writer.write_vector("/fcm_imm/initial_probabilities", spec.initial_probabilities, kDimensionless);
  writer.write_matrix("/fcm_imm/mean_memberships", spec.mean_memberships,
                      {"deceleration", "noise", "acceleration"}, kDimensionless);
}

FcmImmSpec read_fcm_imm(const ModelFileReader& reader) {
  FcmImmSpec spec;
  spec.sample_period = reader.real(kFcmImmGroup, "sample_period", ValueRule::kPositive);
  spec.measurement_sigma = reader.real(kFcmImmGroup, "measurement_sigma", ValueRule::kPositive);
  spec.window =
      static_cast<int>(reader.integer(kFcmImmGroup, "window", 3, SlidingFuzzyCMeans::kMaxWindow));
  spec.clustering.fuzzifier = reader.real(kFcmImmGroup, "fuzzifier", ValueRule::kPositive);
  spec.clustering.tolerance = reader.real(kFcmImmGroup, "tolerance", ValueRule::kPositive);
  spec.clustering.max_iterations =
      static_cast<int>(reader.integer(kFcmImmGroup, "max_iterations", 1, 100000));
  spec.separation = reader.real(kFcmImmGroup, "separation", ValueRule::kNonNegative);
  spec.compensation_gain = reader.real(kFcmImmGroup, "compensation_gain", ValueRule::kProbability);
  spec.compensate_lowest = reader.integer(kFcmImmGroup, "compensate_lowest", 0, 1) == 1;
  try {
    spec.scale =
        membership_scale_from(reader.text(kFcmImmGroup, "membership_scale"), "membership_scale");
  } catch (const InvalidParameter& error) {
    reader.fail(std::string(kFcmImmGroup) + "@" + error.field(), error.what());
  }
  const Eigen::VectorXd q = reader.vector("/fcm_imm/process_noise", -1, ValueRule::kNonNegative);
  if (q.size() < 1 || q.size() > 8) reader.fail("/fcm_imm/process_noise", "need 1 to 8 modes");
  spec.process_noise.assign(q.data(), q.data() + q.size());
  const int n = static_cast<int>(q.size());
  spec.transition = reader.matrix("/fcm_imm/transition", n, n, ValueRule::kProbability);
  spec.initial_probabilities =
      reader.vector("/fcm_imm/initial_probabilities", n, ValueRule::kProbability);
  spec.mean_memberships =
      reader.matrix("/fcm_imm/mean_memberships", n, kFcmClusters, ValueRule::kProbability);
  try {
    spec.validate();
  } catch (const InvalidParameter& error) {
    reader.fail_spec(kFcmImmGroup, error,
                     {"transition", "initial_probabilities", "mean_memberships", "process_noise"});
  }
  reader.require_units_of_reals();
  return spec;
}

FcmImmSpec read_fcm_imm(const std::filesystem::path& path) {
  return read_fcm_imm(ModelFileReader(path, kFcmImmKind));
}

}  // namespace imm::io
