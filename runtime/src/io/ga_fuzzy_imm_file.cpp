// SPDX-License-Identifier: Apache-2.0
#include "imm/io/ga_fuzzy_imm_file.hpp"

#include <cmath>
#include <variant>

#include "imm/core/invalid_parameter.hpp"

namespace imm::io {
namespace {
constexpr const char* kRoot = "/ga_fuzzy_imm";
std::string level_group(std::size_t i) { return std::string(kRoot) + "/level" + std::to_string(i); }
const std::vector<std::string>& ga_rule_columns() {
  static const std::vector<std::string> columns = {"c1", "sigma1", "c2", "sigma2", "w"};
  return columns;
}
}  // namespace

Eigen::MatrixXd rules_matrix(const FuzzyRuleTable& table) {
  Eigen::MatrixXd m(static_cast<Eigen::Index>(table.size()), 5);
  for (std::size_t l = 0; l < table.size(); ++l) {
    const FuzzyRule& r = table.rules()[l];
    m.row(static_cast<Eigen::Index>(l)) << r.c1, r.sigma1, r.c2, r.sigma2, r.w;
  }
  return m;
}

FuzzyRuleTable table_from_matrix(const Eigen::MatrixXd& rules) {
  if (rules.cols() != 5) throw std::invalid_argument("a rule table has 5 columns");
  std::vector<FuzzyRule> list;
  list.reserve(static_cast<std::size_t>(rules.rows()));
  for (Eigen::Index l = 0; l < rules.rows(); ++l) {
    list.push_back({rules(l, 0), rules(l, 1), rules(l, 2), rules(l, 3), rules(l, 4)});
  }
  return FuzzyRuleTable(std::move(list));
}

void write_ga_fuzzy_imm(ModelFileWriter& writer, const GaFuzzyImmSpec& spec,
                        const std::vector<std::vector<LevelMetric>>& level_metrics) {
  spec.validate();
  const AxisImmSettings& s = spec.settings;
  const UnitNames& u = writer.units();
  writer.set_quantity(kRoot, "sample_period", s.sample_period, "s");
  writer.set_quantity(kRoot, "measurement_sigma", s.measurement_sigma, u.length);
  writer.set_quantity(kRoot, "transition_stay", s.transition_stay, kDimensionless);
  writer.set_quantity(kRoot, "initial_first_probability", s.initial_first_probability,
                      kDimensionless);
  // The rules map (residual, residual change), in lengths, or the normalized innovation and its
  // change (dimensionless) to a process-noise variance (fuzzy_noise_filter.hpp). An older reader
  // would read normalized tables as residual ones: such a file is version 3.
  const bool normalized = spec.antecedents == FuzzyAntecedents::kNormalizedInnovation;
  if (normalized) {
    writer.require_schema_version(3);
    writer.set_attribute(kRoot, "antecedents", std::string(to_string(spec.antecedents)));
  }
  const std::string input = normalized ? std::string(kDimensionless) : u.length;
  const std::string rule_units =
      input + "," + input + "," + input + "," + input + "," + u.acceleration_variance();
  writer.set_attribute(kRoot, "level_count", static_cast<std::int64_t>(spec.levels.size()));
  for (std::size_t i = 0; i < spec.levels.size(); ++i) {
    const FuzzyLevel& level = spec.levels[i];
    const std::string group = level_group(i);
    writer.set_attribute(group, "name", level.name);
    writer.set_quantity(group, "maneuver_level", level.maneuver_level, u.acceleration());
    if (i < level_metrics.size()) {
      for (const auto& metric : level_metrics[i]) {
        if (const auto* real = std::get_if<double>(&metric.value)) {
          writer.set_quantity(group, metric.name, *real, metric.units);
        } else {
          writer.set_attribute(group, metric.name, metric.value);
        }
      }
    }
    writer.write_matrix(group + "/rules", rules_matrix(level.table), ga_rule_columns(), rule_units);
  }
}

GaFuzzyImmSpec read_ga_fuzzy_imm(const ModelFileReader& reader) {
  GaFuzzyImmSpec spec;
  AxisImmSettings& s = spec.settings;
  s.sample_period = reader.real(kRoot, "sample_period", ValueRule::kPositive);
  s.measurement_sigma = reader.real(kRoot, "measurement_sigma", ValueRule::kPositive);
  s.transition_stay = reader.real(kRoot, "transition_stay", ValueRule::kProbability);
  s.initial_first_probability =
      reader.real(kRoot, "initial_first_probability", ValueRule::kProbability);
  // Version 3 may name the antecedents; older files hold the seed's residual tables (a reader of
  // their version would ignore the attribute, so an older file must not carry it).
  if (reader.container().attribute(kRoot, "antecedents")) {
    const std::string field = std::string(kRoot) + "@antecedents";
    if (reader.schema_version() < 3) reader.fail(field, "needs schema version 3");
    try {
      spec.antecedents = fuzzy_antecedents_from(reader.text(kRoot, "antecedents"), field);
    } catch (const InvalidParameter& error) {
      reader.fail(field, error.message());
    }
  }
  const auto n = reader.integer(kRoot, "level_count", 1, 8);
  for (std::int64_t i = 0; i < n; ++i) {
    const std::string group = level_group(static_cast<std::size_t>(i));
    FuzzyLevel level;
    level.name = reader.text(group, "name");
    level.maneuver_level = reader.real(group, "maneuver_level", ValueRule::kNonNegative);
    // The training's counts (metadata no filter reads) are counts all the same: integers in range.
    // (Schema version 1 wrote them as reals: an integral value in range is a count there too.)
    for (const auto& [count, most] :
         {std::pair{"generations", std::int64_t{100'000'000}},
          std::pair{"rules", std::int64_t{FuzzyRuleTable::kMaxRules}}}) {
      const auto value = reader.container().attribute(group, count);
      if (!value) continue;
      const auto* real = std::get_if<double>(&*value);
      if (real != nullptr && reader.schema_version() == 1) {
        if (!(*real >= 0.0 && *real <= static_cast<double>(most) && std::floor(*real) == *real)) {
          reader.fail(group + "@" + count, "value " + std::to_string(*real) +
                                               " is not a count in [0, " + std::to_string(most) +
                                               "]");
        }
      } else {
        (void)reader.integer(group, count, 0, most);
      }
    }
    const Eigen::MatrixXd rules = reader.matrix(group + "/rules", -1, 5);
    if (rules.rows() < 1 || rules.rows() > static_cast<Eigen::Index>(FuzzyRuleTable::kMaxRules)) {
      reader.fail(group + "/rules", "needs 1 to 50 rules, found " + std::to_string(rules.rows()));
    }
    try {
      level.table = table_from_matrix(rules);
    } catch (const std::invalid_argument& error) {
      reader.fail(group + "/rules", error.what());
    }
    spec.levels.push_back(std::move(level));
  }
  try {
    spec.validate();
  } catch (const InvalidParameter& error) {
    reader.fail(std::string(kRoot) + "@" + error.field(), error.what());
  }
  reader.require_units_of_reals();
  return spec;
}

GaFuzzyImmSpec read_ga_fuzzy_imm(const std::filesystem::path& path) {
  return read_ga_fuzzy_imm(ModelFileReader(path, kGaFuzzyImmKind));
}

}  // namespace imm::io
