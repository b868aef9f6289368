// SPDX-License-Identifier: Apache-2.0
#include "imm/io/tsk_sensor_file.hpp"

#include "imm/core/invalid_parameter.hpp"

namespace imm::io {
namespace {

constexpr const char* kTskGroup = "/tsk";
constexpr const char* kFimmGroup = "/fimm";
const std::vector<std::string>& tsk_rule_columns() {
  static const std::vector<std::string> columns = {
      "center_xi", "width_xi", "center_eta", "width_eta", "a0", "a_xi", "a_eta"};
  return columns;
}

std::string output_group(int i) { return "/tsk/output" + std::to_string(i + 1); }

}  // namespace

Eigen::MatrixXd rules_matrix(const std::vector<TskRule>& rules) {
  Eigen::MatrixXd m(static_cast<Eigen::Index>(rules.size()), 7);
  for (std::size_t r = 0; r < rules.size(); ++r) {
    const TskRule& rule = rules[r];
    m.row(static_cast<Eigen::Index>(r)) << rule.center(0), rule.width(0), rule.center(1),
        rule.width(1), rule.consequent(0), rule.consequent(1), rule.consequent(2);
  }
  return m;
}

std::vector<TskRule> rules_from_matrix(const Eigen::MatrixXd& matrix) {
  std::vector<TskRule> rules(static_cast<std::size_t>(matrix.rows()));
  for (Eigen::Index r = 0; r < matrix.rows(); ++r) {
    TskRule& rule = rules[static_cast<std::size_t>(r)];
    rule.center << matrix(r, 0), matrix(r, 2);
    rule.width << matrix(r, 1), matrix(r, 3);
    rule.consequent << matrix(r, 4), matrix(r, 5), matrix(r, 6);
  }
  return rules;
}

void write_tsk_sensor(ModelFileWriter& writer, const TskSensorModel& model) {
  writer.set_attribute(kTskGroup, "t_norm", std::string(to_string(model.t_norm())));
  writer.set_attribute(kTskGroup, "inputs", std::string("xi,eta"));
  writer.set_attribute(kTskGroup, "outputs", std::string("z1,z2"));
  Eigen::Matrix2d box;
  box.row(0) = model.input_lower().transpose();
  box.row(1) = model.input_upper().transpose();
  const UnitNames& u = writer.units();
  writer.write_matrix("/tsk/input_box", box, {"xi", "eta"}, u.length);
  // Premises on (ξ, η) and the outputs in lengths; the consequents' slopes a_ξ, a_η are ratios.
  const std::string rule_units =
      u.length + "," + u.length + "," + u.length + "," + u.length + "," + u.length + ",1,1";
  for (int i = 0; i < 2; ++i) {
    const TskOutput& out = model.outputs()[static_cast<std::size_t>(i)];
    writer.write_matrix(output_group(i) + "/rules", rules_matrix(out.rules), tsk_rule_columns(),
                        rule_units);
    writer.set_quantity(output_group(i), "sigma", out.sigma, u.length);
  }
}

TskSensorModel read_tsk_sensor(const ModelFileReader& reader) {
  TNorm t_norm = TNorm::kMin;
  try {
    t_norm = t_norm_from(reader.text(kTskGroup, "t_norm"), "t_norm");
  } catch (const InvalidParameter& error) {
    reader.fail(std::string(kTskGroup) + "@t_norm", error.what());
  }
  const Eigen::MatrixXd box = reader.matrix("/tsk/input_box", 2, 2);
  std::array<TskOutput, 2> outputs;
  for (int i = 0; i < 2; ++i) {
    const Eigen::MatrixXd rules = reader.matrix(output_group(i) + "/rules", -1, 7);
    if (rules.rows() < 1 || rules.rows() > TskSensorModel::kMaxRules) {
      reader.fail(output_group(i) + "/rules",
                  "need 1 to " + std::to_string(TskSensorModel::kMaxRules) + " rules");
    }
    for (Eigen::Index r = 0; r < rules.rows(); ++r) {
      if (!(rules(r, 1) > 0.0) || !(rules(r, 3) > 0.0)) {
        reader.fail(output_group(i) + "/rules",
                    "row " + std::to_string(r) + ": premise widths must be positive");
      }
    }
    outputs[static_cast<std::size_t>(i)].rules = rules_from_matrix(rules);
    outputs[static_cast<std::size_t>(i)].sigma =
        reader.real(output_group(i), "sigma", ValueRule::kNonNegative);
  }
  reader.require_units_of_reals();
  try {
    return TskSensorModel(std::move(outputs), t_norm, box.row(0).transpose(),
                          box.row(1).transpose());
  } catch (const InvalidParameter& error) {
    // The model's field ("outputs[1].rules[2].width", "input_upper") as the file's.
    const std::string& f = error.field();
    std::string field = "/tsk/input_box";
    if (f.rfind("outputs[", 0) == 0 && f.size() > 9) {
      const int i = f[8] - '0';
      field = output_group(i) + (f.find(".sigma") != std::string::npos ? "@sigma" : "/rules");
    }
    reader.fail(field, error.what());
  }
}

TskSensorModel read_tsk_sensor(const std::filesystem::path& path) {
  return read_tsk_sensor(ModelFileReader(path, kTskSensorKind));
}

void write_fimm_settings(ModelFileWriter& writer, const FimmSpec& spec) {
  spec.validate();
  const UnitNames& u = writer.units();
  writer.set_quantity(kFimmGroup, "sample_period", spec.sample_period, "s");
  // √q₁ per step (fimm.hpp): an acceleration standard deviation.
  writer.set_quantity(kFimmGroup, "cruise_sigma", spec.cruise_sigma, u.acceleration());
  writer.set_quantity(kFimmGroup, "lane_change_ratio", spec.lane_change_ratio, kDimensionless);
  writer.set_quantity(kFimmGroup, "noise_scale", spec.noise_scale, kDimensionless);
  writer.set_attribute(kFimmGroup, "iterations", std::int64_t{spec.iterations});
  writer.set_quantity(kFimmGroup, "acceleration_variance", spec.acceleration_variance,
                      u.acceleration_variance());
  writer.write_matrix("/fimm/transition", spec.transition, {"cruise", "lane_change"},
                      kDimensionless);
  writer.write_vector("/fimm/initial_probabilities", spec.initial_probabilities, kDimensionless);
  writer.write_covariance("/fimm/measurement_covariance", spec.measurement_covariance, {"z1", "z2"},
                          u.length + "," + u.length);
}

std::optional<FimmSpec> read_fimm_settings(const ModelFileReader& reader) {
  if (reader.container().kind(kFimmGroup) == ObjectKind::kMissing) return std::nullopt;
  FimmSpec spec;
  spec.sample_period = reader.real(kFimmGroup, "sample_period", ValueRule::kPositive);
  spec.cruise_sigma = reader.real(kFimmGroup, "cruise_sigma", ValueRule::kPositive);
  spec.lane_change_ratio = reader.real(kFimmGroup, "lane_change_ratio", ValueRule::kPositive);
  spec.noise_scale = reader.real(kFimmGroup, "noise_scale", ValueRule::kPositive);
  spec.iterations = static_cast<int>(reader.integer(kFimmGroup, "iterations", 1, 100));
  spec.acceleration_variance =
      reader.real(kFimmGroup, "acceleration_variance", ValueRule::kNonNegative);
  spec.transition = reader.matrix("/fimm/transition", 2, 2, ValueRule::kProbability);
  spec.initial_probabilities =
      reader.vector("/fimm/initial_probabilities", 2, ValueRule::kProbability);
  spec.measurement_covariance = reader.matrix("/fimm/measurement_covariance", 2, 2);
  try {
    spec.validate();
  } catch (const InvalidParameter& error) {
    reader.fail_spec(kFimmGroup, error,
                     {"transition", "initial_probabilities", "measurement_covariance"});
  }
  reader.require_units_of_reals();
  return spec;
}

}  // namespace imm::io
