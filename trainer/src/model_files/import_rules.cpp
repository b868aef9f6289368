// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/model_files/import_rules.hpp"

#include <array>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include "imm/datasets/sha256.hpp"
#include "imm/io/ga_fuzzy_imm_file.hpp"
#include "imm/support/csv.hpp"
#include "imm/trainer/ga/ga_config.hpp"
#include "imm/trainer/ga/ga_trainer.hpp"
#include "imm/trainer/model_files/write_model.hpp"
#include "imm/trainer/provenance.hpp"

namespace imm::trainer {

GaFuzzyImmSpec read_rules_csv(const std::filesystem::path& csv, const AxisImmSettings& settings,
                              const std::string& units) {
  std::ifstream in(csv);
  if (!in) throw std::runtime_error(csv.string() + ": cannot open");
  std::vector<double> level_order;
  std::map<double, std::vector<FuzzyRule>> rules;
  bool header = false;
  std::map<std::string, std::string> stated;  // the "#@ key = value" lines
  support::CsvReader reader(in, csv.string(), /*directives=*/true);
  support::CsvLine line;
  static const std::vector<std::string_view> kColumns = {"level", "c1",     "sigma1",
                                                         "c2",    "sigma2", "w"};
  while (reader.next(line)) {
    if (line.directive) {
      stated[std::string(line.key)] = std::string(line.value);
      continue;
    }
    if (!header) {
      if (line.fields != kColumns) reader.fail("expected the header level,c1,sigma1,c2,sigma2,w");
      header = true;
      continue;
    }
    if (line.fields.size() != kColumns.size()) {
      reader.fail("expected 6 fields, found " + std::to_string(line.fields.size()));
    }
    std::array<double, 6> values{};
    for (std::size_t i = 0; i < values.size(); ++i) values[i] = reader.real(line, i, kColumns[i]);
    if (rules.find(values[0]) == rules.end()) level_order.push_back(values[0]);
    rules[values[0]].push_back({values[1], values[2], values[3], values[4], values[5]});
  }
  if (!header) throw std::runtime_error(csv.string() + ": no header line");
  // What the tables were learned for against the regime they are imported for.
  auto number_of = [&](const std::string& key) -> double {
    const auto it = stated.find(key);
    if (it == stated.end()) {
      throw std::runtime_error(csv.string() + ": no '#@ " + key + " = …' line: the tables must " +
                               "state what they were learned for");
    }
    const std::optional<double> value = support::parse_real(it->second);
    if (!value) {
      throw std::runtime_error(csv.string() + ": '#@ " + key + " = " + it->second +
                               "': not a finite number");
    }
    return *value;
  };
  if (const auto it = stated.find("units"); it == stated.end() || it->second != units) {
    throw std::runtime_error(csv.string() + ": the tables are in " +
                             (it == stated.end() ? std::string("unstated units") : it->second) +
                             ", the regime (units) in " + units);
  }
  for (const auto& [key, value] :
       {std::pair<std::string, double>{"sample_period", settings.sample_period},
        {"measurement_sigma", settings.measurement_sigma}}) {
    const double published = number_of(key);
    if (std::abs(published - value) > 1e-9 * std::max(1.0, std::abs(value))) {
      throw std::runtime_error(csv.string() + ": the tables were learned for " + key + " = " +
                               stated[key] + ", the regime has " + std::to_string(value));
    }
  }
  GaFuzzyImmSpec spec;
  spec.settings = settings;
  for (double level : level_order) {
    try {
      spec.levels.push_back({ga::level_name(level), level, FuzzyRuleTable(rules[level])});
    } catch (const std::invalid_argument& error) {
      throw std::runtime_error(csv.string() + ": level " + ga::level_name(level) + ": " +
                               error.what());
    }
  }
  try {
    spec.validate();
  } catch (const std::invalid_argument& error) {
    throw std::runtime_error(csv.string() + ": " + error.what());
  }
  return spec;
}

GaFuzzyImmSpec import_rules(const ImportRulesOptions& options) {
  const ga::GaTrainingConfig config = ga::load_ga_config(options.config, options.regime);
  GaFuzzyImmSpec spec = read_rules_csv(options.csv, config.filter,
                                       std::string(datasets::to_string(config.regime.units)));
  const std::string csv_text = read_text_file(options.csv);
  write_model_file(
      options.out,
      make_provenance(std::string(io::kGaFuzzyImmKind),
                      "# filter settings: " + options.config.string() + "\n" + config.text +
                          "\n# rules: " + options.csv.string() + "\n" + csv_text,
                      0, datasets::sha256_hex(csv_text), config.regime),
      [&](io::ModelFileWriter& writer) { io::write_ga_fuzzy_imm(writer, spec); });
  return spec;
}

}  // namespace imm::trainer
