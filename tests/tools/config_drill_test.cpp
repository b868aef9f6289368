// SPDX-License-Identifier: Apache-2.0
// The config drill: every numeric key of every shipped config, set in turn to 0, −1, 1e-320,
// 1e308, NaN and inf, given to the tool that reads it, as a separate process with a time limit.
// Each run must either be refused at load (exit 2, one line on stderr naming the file and the
// key) or run to its end (exit 0, or 4/5 for a quality gate) — never hang, abort, or fail with
// an error that does not say which key to fix.
//
// The expensive knobs of each config are first shrunk (population, epochs, trajectories, ...) so
// that an accepted mutation trains in a fraction of a second; the mutated key wins over the
// shrinking.

#include <gtest/gtest.h>
#include <toml++/toml.h>

#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>

#include "testing/run_tool.hpp"
#include "testing/study.hpp"
#include "testing/temp_dir.hpp"

namespace imm {
namespace {

struct DrillTarget {
  std::string name;
  std::string config;                                 ///< shipped config, relative to the root
  std::vector<std::pair<std::string, double>> quick;  ///< key path (dotted) → value
  std::string tool;
  /// The tool's arguments; "{config}", "{dir}", "{plots}" and "{regime}" are replaced.
  std::vector<std::string> arguments;
  /// A regime preset the tool gets as {regime}, shrunk by `regime_quick` (not drilled here: the
  /// regime files are drilled as targets of their own).
  std::string regime = "";
  std::vector<std::pair<std::string, double>> regime_quick = {};
  /// The model's regime: its classical IMM is tuned once into {dir}/classical.h5, which the
  /// arguments pass as --classical (every run would tune it again otherwise).
  std::string classical_regime = "";
};

void PrintTo(const DrillTarget& target, std::ostream* out) { *out << target.name; }

/// A leaf of the document: its path in the loaders' notation ("fuzzy.sigma_range[1]",
/// "data.training[0].maneuvers[2][1]") and the key a loader should name for it (the path without
/// the trailing array indices of numbers).
struct Leaf {
  std::string path;
  std::string key;
  bool integer = false;
  toml::node* node = nullptr;
};

std::string strip_number_indices(const std::string& path) {
  std::string key = path;
  while (!key.empty() && key.back() == ']') key.erase(key.rfind('['));
  return key;
}

void collect(toml::node& node, const std::string& path, std::vector<Leaf>& leaves) {
  if (auto* table = node.as_table()) {
    for (auto& [key, child] : *table) {
      collect(child, path.empty() ? std::string(key.str()) : path + "." + std::string(key.str()),
              leaves);
    }
  } else if (auto* array = node.as_array()) {
    for (std::size_t i = 0; i < array->size(); ++i) {
      collect(*array->get(i), path + "[" + std::to_string(i) + "]", leaves);
    }
  } else if (node.is_integer() || node.is_floating_point()) {
    leaves.push_back({path, strip_number_indices(path), node.is_integer(), &node});
  }
}

/// Sets a key given in the loaders' notation ("ga.population", "training.phases[1].epochs").
void set_path(toml::table& root, const std::string& path, double value) {
  toml::table* table = &root;
  std::string rest = path;
  for (std::size_t dot = rest.find('.'); dot != std::string::npos; dot = rest.find('.')) {
    std::string segment = rest.substr(0, dot);
    rest = rest.substr(dot + 1);
    const std::size_t bracket = segment.find('[');
    if (bracket == std::string::npos) {
      table = (*table)[segment].as_table();
    } else {
      const auto index = std::stoul(segment.substr(bracket + 1));
      auto* array = (*table)[segment.substr(0, bracket)].as_array();
      ASSERT_NE(array, nullptr) << path;
      table = array->get(index)->as_table();
    }
    ASSERT_NE(table, nullptr) << path;
  }
  ASSERT_TRUE(table->contains(rest)) << "no key " << path;
  if ((*table)[rest].is_integer()) {
    table->insert_or_assign(rest, static_cast<std::int64_t>(value));
  } else {
    table->insert_or_assign(rest, value);
  }
}

std::string render(const toml::table& table) {
  std::ostringstream out;
  out << toml::toml_formatter(
      table, toml::toml_formatter::default_flags & ~toml::format_flags::allow_literal_strings);
  return out.str();
}

std::string replace_all(std::string text, const std::string& from, const std::string& to) {
  for (std::size_t at = text.find(from); at != std::string::npos; at = text.find(from, at)) {
    text.replace(at, from.size(), to);
    at += to.size();
  }
  return text;
}

class ConfigDrill : public ::testing::TestWithParam<DrillTarget> {};

TEST_P(ConfigDrill, EveryNumericKeyAtEveryAbsurdValueIsRefusedNamingTheKeyOrRuns) {
  const DrillTarget& target = GetParam();
  const auto root = testing::source_root();
  toml::table base = toml::parse_file((root / target.config).string());
  for (const auto& [key, value] : target.quick) set_path(base, key, value);

  std::vector<Leaf> leaves;
  collect(base, "", leaves);
  ASSERT_FALSE(leaves.empty());

  const testing::TempDir dir;
  const auto config_path = dir / "drill.toml";
  const auto plots = dir / "plots.csv";
  const auto data = testing::run_tool(
      "imm-data",
      {"tracks", "--regime", "configs/regimes/paper/ga_imm_table3.toml", "--count", "1", "--out",
       (dir / "plots.h5").string(), "--csv", plots.string()},
      root);
  ASSERT_EQ(data.exit_code, 0) << data.err;
  const auto regime_path = dir / "regime.toml";
  if (!target.regime.empty()) {
    toml::table regime = toml::parse_file((root / target.regime).string());
    for (const auto& [key, value] : target.regime_quick) set_path(regime, key, value);
    testing::write_text(regime_path, render(regime));
  }
  if (!target.classical_regime.empty()) {
    const auto classical =
        testing::run_tool("imm-train",
                          {"baseline", "--config", "configs/classical_imm.toml", "--regime",
                           target.classical_regime, "--out", (dir / "classical.h5").string()},
                          root);
    ASSERT_EQ(classical.exit_code, 0) << classical.err;
  }
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const std::vector<double> values = {
      0.0, -1.0, 1e-320, 1e308, std::numeric_limits<double>::quiet_NaN(), kInf};
  std::size_t runs = 0, refused = 0;
  std::vector<std::string> failures;
  // The default suite drills every key at two of the absurd values (key l at values l and l + 3,
  // so each value is met across the keys); `make test-long` at all of them; the sanitized suite
  // at one (value l), every key and every value still met there.
  const bool every_value = testing::running_as_study();
  const bool second_value = !testing::running_sanitized();
  for (std::size_t l = 0; l < leaves.size(); ++l) {
    for (std::size_t v = 0; v < values.size(); ++v) {
      const bool drilled = v == l % values.size() || (second_value && v == (l + 3) % values.size());
      if (!every_value && !drilled) continue;
      const double value = values[v];
      toml::table mutated = base;
      std::vector<Leaf> copies;
      collect(mutated, "", copies);
      toml::node& node = *copies[l].node;
      const bool integral = leaves[l].integer && (value == 0.0 || value == -1.0);
      std::ostringstream text;
      if (integral) {
        text << static_cast<std::int64_t>(value);
      } else if (std::isnan(value)) {
        text << "nan";
      } else if (std::isinf(value)) {
        text << "inf";
      } else {
        text << std::setprecision(17) << value;
      }
      // A node cannot change its type in place: write a unique marker and replace its text.
      const std::string marker = leaves[l].integer ? "987654321987654321" : "1234567.25";
      if (auto* i = node.as_integer()) *i = 987654321987654321;
      if (auto* f = node.as_floating_point()) *f = 1234567.25;
      const std::string marked = render(mutated);
      ASSERT_NE(marked.find(marker), std::string::npos) << leaves[l].path << "\n" << marked;
      const std::string rendered = replace_all(marked, marker, text.str());
      const Leaf& leaf = leaves[l];
      testing::write_text(config_path, rendered);
      std::vector<std::string> arguments;
      for (const std::string& argument : target.arguments) {
        arguments.push_back(replace_all(
            replace_all(replace_all(replace_all(argument, "{config}", config_path.string()),
                                    "{dir}", dir.path().string()),
                        "{plots}", plots.string()),
            "{regime}", regime_path.string()));
      }
      const auto result = testing::run_tool(target.tool, arguments, root, 60.0);
      ++runs;
      const std::string what = leaf.path + " = " + text.str();
      if (result.exit_code == testing::kTimedOut) {
        failures.push_back(what + ": no answer within 60 s");
      } else if (result.exit_code >= 128) {
        failures.push_back(what + ": killed by signal " + std::to_string(result.exit_code - 128) +
                           ": " + result.err);
      } else if (result.exit_code == 2) {
        ++refused;
        const bool one_line = std::count(result.err.begin(), result.err.end(), '\n') == 1;
        // The key itself, or the table or array that holds it when the rule spans its members
        // (a regime's maneuver probabilities must sum to 1: "key 'maneuvers'").
        bool names_key = result.err.find("key '" + leaf.key) != std::string::npos;
        for (std::size_t cut = leaf.key.find_first_of(".["); !names_key && cut != std::string::npos;
             cut = leaf.key.find_first_of(".[", cut + 1)) {
          names_key = result.err.find("key '" + leaf.key.substr(0, cut) + "'") != std::string::npos;
        }
        const bool names_file = result.err.find(config_path.string()) != std::string::npos;
        if (!one_line || !names_key || !names_file) {
          failures.push_back(what + ": refused without naming the key on one line: " + result.err);
        }
      } else if (result.exit_code != 0 && result.exit_code != 4 && result.exit_code != 5 &&
                 result.exit_code != 7) {
        failures.push_back(what + ": exit " + std::to_string(result.exit_code) + ": " + result.err);
      }
    }
  }
  std::cout << target.name << ": " << runs << " runs over " << leaves.size() << " keys, " << refused
            << " refused at load, " << failures.size() << " failures\n";
  for (const std::string& failure : failures) ADD_FAILURE() << failure;
}

INSTANTIATE_TEST_SUITE_P(
    Configs, ConfigDrill,
    ::testing::Values(
        DrillTarget{"ga",
                    "configs/ga_fuzzy_imm.toml",
                    {{"ga.population", 8}, {"ga.generations", 2}},
                    "imm-train",
                    {"ga", "--config", "{config}", "--regime", "{regime}", "--out", "{dir}/m.h5",
                     "--threads", "1"},
                    "configs/regimes/paper/ga_imm_training.toml",
                    {{"scans", 40}, {"splits.training", 1}, {"splits.validation", 1}}},
        DrillTarget{"import_rules",
                    "configs/ga_fuzzy_imm.toml",
                    {},
                    "imm-train",
                    {"import-rules", "--config", "{config}", "--csv",
                     "configs/reference/ga_fuzzy_imm_paper_rules.csv", "--out", "{dir}/m.h5"}},
        DrillTarget{"mlp",
                    "configs/mlp_input_estimator.toml",
                    {{"training.phases[0].epochs", 3}, {"training.phases[1].epochs", 3}},
                    "imm-train",
                    {"mlp", "--config", "{config}", "--regime", "{regime}", "--out", "{dir}/m.h5"},
                    "configs/regimes/paper/input_estimator_training.toml",
                    {{"scans", 150}}},
        DrillTarget{"wimm",
                    "configs/wimm.toml",
                    {{"tuning.max_evaluations", 4}},
                    "imm-train",
                    {"wimm", "--config", "{config}", "--regime", "{regime}", "--out", "{dir}/m.h5"},
                    "configs/regimes/paper/wimm_training.toml",
                    {{"scans", 60}, {"splits.training", 2}}},
        DrillTarget{"fcm",
                    "configs/fcm_imm.toml",
                    {{"tuning.max_evaluations", 4}},
                    "imm-train",
                    {"fcm", "--config", "{config}", "--regime", "{regime}", "--out", "{dir}/m.h5"},
                    "configs/regimes/paper/fcm_imm_training.toml",
                    {{"scans", 100}, {"splits.training", 2}, {"splits.validation", 1}}},
        DrillTarget{
            "schedule",
            "configs/scheduled_ct_imm.toml",
            {{"classical.grid_points", 2},
             {"classical.polish_evaluations", 4},
             {"schedule.evaluations", 4}},
            "imm-train",
            {"schedule", "--config", "{config}", "--regime", "{regime}", "--out", "{dir}/m.h5"},
            "configs/regimes/agile_air.toml",
            {{"scans", 40}, {"splits.training", 2}, {"splits.validation", 1}}},
        DrillTarget{
            "tsk",
            "configs/tsk_range_sensor.toml",
            {{"fit.restarts", 2}, {"fit.max_iterations", 30}, {"fit.fine_tuning_iterations", 10}},
            "imm-train",
            {"tsk", "--config", "{config}", "--regime", "{regime}", "--out", "{dir}/m.h5"},
            "configs/regimes/paper/fimm_table1.toml",
            {{"sensor.calibration.samples", 300}}},
        DrillTarget{"freeze",
                    "configs/track/cv3_imm.toml",
                    {},
                    "imm-train",
                    {"freeze", "--config", "{config}", "--out", "{dir}/m.h5"}},
        // The regime files: every number of every kind of regime (random and scripted, each
        // sensor), drawn from by imm-data.
        DrillTarget{"regime_random_cartesian",
                    "configs/regimes/paper/fcm_imm_training.toml",
                    {},
                    "imm-data",
                    {"tracks", "--regime", "{config}", "--count", "2", "--out", "{dir}/d.h5"}},
        DrillTarget{"regime_random_polar",
                    "configs/regimes/paper/wimm_training.toml",
                    {},
                    "imm-data",
                    {"tracks", "--regime", "{config}", "--count", "2", "--out", "{dir}/d.h5"}},
        DrillTarget{"regime_scripted",
                    "configs/regimes/paper/input_estimator_tables.toml",
                    {},
                    "imm-data",
                    {"tracks", "--regime", "{config}", "--count", "2", "--out", "{dir}/d.h5"}},
        DrillTarget{"regime_range_sensor",
                    "configs/regimes/paper/fimm_table1.toml",
                    {{"sensor.calibration.samples", 300}},
                    "imm-data",
                    {"sensor", "--regime", "{config}", "--out", "{dir}/d.h5"}},
        DrillTarget{"ga_imm_evaluation",
                    "configs/regimes/paper/ga_imm_table3.toml",
                    {},
                    "imm-eval",
                    {"ga-imm", "--regime", "{config}", "--models", "models", "--runs", "2", "--out",
                     "{dir}/report", "--classical", "{dir}/classical.h5"},
                    "",
                    {},
                    "configs/regimes/paper/ga_imm_training.toml"},
        DrillTarget{"wimm_evaluation",
                    "configs/regimes/paper/wimm_table2.toml",
                    {},
                    "imm-eval",
                    {"wimm", "--regime", "{config}", "--models", "models", "--runs", "2", "--out",
                     "{dir}/report", "--classical", "{dir}/classical.h5"},
                    "",
                    {},
                    "configs/regimes/paper/wimm_training.toml"},
        DrillTarget{"fimm_evaluation",
                    "configs/tsk_range_sensor.toml",
                    {},
                    "imm-eval",
                    {"fimm", "--config", "{config}", "--models", "models", "--runs", "4", "--out",
                     "{dir}/report"}},
        DrillTarget{"track",
                    "configs/track/cv3_imm.toml",
                    {},
                    "imm-track",
                    {"--filter", "{config}", "--measurements", "{plots}", "--out", "{dir}/t.csv"}}),
    [](const ::testing::TestParamInfo<DrillTarget>& param) { return param.param.name; });

}  // namespace
}  // namespace imm
