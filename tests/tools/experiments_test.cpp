// SPDX-License-Identifier: Apache-2.0
// The experiments as a library (imm/evaluation/experiments.hpp): evaluate_* computes and writes
// nothing; its typed result holds what report_* then prints and writes, to the bit; and the
// filters' figures are those of the Monte Carlo loop run by hand on the same test tracks.

#include "imm/evaluation/experiments.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "imm/io/plain_imm_file.hpp"
#include "imm/support/exit_codes.hpp"
#include "testing/temp_dir.hpp"

namespace imm::testing {
namespace {

using evaluation::FilterOutcome;

nlohmann::json read_json(const std::filesystem::path& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

TEST(Experiments, PlainImmResultIsWhatItsReportWritesAndWhatTheLoopGives) {
  const TempDir dir;
  evaluation::PlainImmOptions options;
  options.common.runs = 8;
  options.common.out = dir / "plain";
  const evaluation::PlainImmResult result = evaluation::evaluate_plain_imm(options);
  EXPECT_FALSE(std::filesystem::exists(options.common.out)) << "evaluate_* writes nothing";
  ASSERT_EQ(result.runs(), 8);
  EXPECT_EQ(result.experiment, "plain-imm");
  EXPECT_FALSE(result.scheduled);

  // The IMM first, then each of its three modes alone; the IMM's figures are the loop's own.
  const PlainImmSpec spec =
      io::read_plain_imm(io::ModelFileReader(result.model, io::kPlainImmKind));
  ASSERT_EQ(result.filters.size(), 1 + spec.modes.size());
  const FilterOutcome by_hand = evaluation::run_monte_carlo(
      "imm", [&] { return make_plain_imm_filter(spec); }, spec.track_options(), result.tracks);
  const FilterOutcome& imm = result.filters.front();
  EXPECT_EQ(imm.zeta_p, by_hand.zeta_p);
  EXPECT_EQ(imm.zeta_v, by_hand.zeta_v);
  EXPECT_EQ(imm.position_rmse, by_hand.position_rmse);
  ASSERT_EQ(result.imm_minus.size(), spec.modes.size());
  for (const auto& [name, d] : result.imm_minus) {
    EXPECT_NO_THROW((void)result.filter(name));
    EXPECT_LE(d.zeta_p.lower, d.zeta_p.estimate) << name;
    EXPECT_LE(d.zeta_p.estimate, d.zeta_p.upper) << name;
  }
  EXPECT_THROW((void)result.filter("no such filter"), std::out_of_range);

  EXPECT_EQ(evaluation::report_plain_imm(result, options), result.exit_code());
  const nlohmann::json metrics = read_json(options.common.out / "metrics.json");
  const nlohmann::json& rows = metrics["results"]["rows"];
  ASSERT_EQ(rows.size(), result.filters.size());
  for (std::size_t f = 0; f < result.filters.size(); ++f) {
    EXPECT_EQ(rows[f]["filter"], result.filters[f].name);
    EXPECT_EQ(rows[f]["zeta_p"].get<double>(), result.filters[f].zeta_p);
    EXPECT_EQ(rows[f]["zeta_v"].get<double>(), result.filters[f].zeta_v);
    EXPECT_EQ(rows[f]["position_nees"].get<double>(),
              result.filters[f].position_consistency.average);
  }
  EXPECT_EQ(metrics["results"]["dataset_digest"], result.tracks.digest());
}

// A model is never evaluated on tracks of another length unit (its R and Q would be read 1000
// times off): cv3_imm works in km, agile_air in m.
TEST(Experiments, PlainImmRefusesTracksOfAnotherLengthUnitNamingBoth) {
  evaluation::PlainImmOptions options;
  options.common.runs = 2;
  options.common.regime = "configs/regimes/agile_air.toml";
  options.common.model = "models/cv3_imm.h5";
  try {
    (void)evaluation::evaluate_plain_imm(options);
    ADD_FAILURE() << "evaluated a km model on a regime in m";
  } catch (const std::runtime_error& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("length_unit: the model works in km"), std::string::npos) << message;
    EXPECT_NE(message.find("agile_air"), std::string::npos) << message;
    EXPECT_NE(message.find(" in m"), std::string::npos) << message;
  }
}

TEST(Experiments, GaImmResultIsWhatItsReportWrites) {
  const TempDir dir;
  evaluation::GaImmOptions options;
  options.common.runs = 6;
  options.common.out = dir / "ga";
  // The shipped CV/CA/CT IMM of the model's regime, when there is one, spares the search.
  const evaluation::GaImmResult result = evaluation::evaluate_ga_imm(options);
  EXPECT_FALSE(std::filesystem::exists(options.common.out)) << "evaluate_* writes nothing";
  ASSERT_EQ(result.runs(), 6);
  for (const char* name : {"AIMM3", "AIMM5", "AIMM-tuned", "IMM-tuned", "GA-IMM"}) {
    EXPECT_NO_THROW((void)result.filter(name)) << name;
    EXPECT_TRUE(result.training_scores.contains(name)) << name;
  }
  // GA-IMM against every other filter, and nothing against itself.
  EXPECT_EQ(result.ga_imm_minus.size(), result.filters.size() - 1);
  EXPECT_FALSE(result.ga_imm_minus.contains("GA-IMM"));
  EXPECT_TRUE(result.against_imm_tuned == "beats" || result.against_imm_tuned == "ties" ||
              result.against_imm_tuned == "loses to")
      << result.against_imm_tuned;
  // q_j(k)'s percentiles are ordered, one row per level of each fuzzy filter.
  ASSERT_FALSE(result.spreads.empty());
  for (const auto& s : result.spreads) {
    EXPECT_LE(s.p01, s.p50) << s.filter << " " << s.mode;
    EXPECT_LE(s.p50, s.p99) << s.filter << " " << s.mode;
  }

  const int code = evaluation::report_ga_imm(result, options);
  EXPECT_EQ(code, result.exit_code());
  EXPECT_TRUE(code == 0 || code == support::exit_code::kFindings ||
              code == support::exit_code::kEvaluationGateFailed)
      << code;
  const nlohmann::json metrics = read_json(options.common.out / "metrics.json");
  for (const FilterOutcome& f : result.filters) {
    ASSERT_TRUE(metrics["results"].contains(f.name)) << f.name;
    EXPECT_EQ(metrics["results"][f.name]["zeta_p"].get<double>(), f.zeta_p) << f.name;
    EXPECT_EQ(metrics["results"][f.name]["zeta_v"].get<double>(), f.zeta_v) << f.name;
    EXPECT_EQ(metrics["results"][f.name]["nis"].get<double>(), f.nis_consistency.average) << f.name;
  }
  const nlohmann::json details = read_json(options.common.out / "details.json");
  EXPECT_EQ(details["findings"].get<std::vector<std::string>>(), result.findings);
  EXPECT_EQ(details["gate_failures"].get<std::vector<std::string>>(), result.failures);
  for (const auto& [name, d] : result.ga_imm_minus) {
    EXPECT_EQ(details["ga_imm_minus"][name]["zeta_p"][0].get<double>(), d.zeta_p.estimate) << name;
    EXPECT_EQ(details["ga_imm_minus"][name]["zeta_v"][2].get<double>(), d.zeta_v.upper) << name;
  }
}

TEST(Experiments, RankResultIsWhatTrackerJsonRecords) {
  const TempDir dir;
  evaluation::RankOptions options;
  options.baselines = {"models/baseline_imm_agile_air.h5", "models/classical_imm_agile_air.h5"};
  options.candidates = {"models/ga_fuzzy_imm_agile_air.h5"};
  options.runs = 5;
  options.out = dir / "rank";
  const evaluation::RankResult result = evaluation::evaluate_rank(options);
  EXPECT_FALSE(std::filesystem::exists(options.out)) << "evaluate_* writes nothing";
  ASSERT_EQ(result.filters.size(), 3U);
  ASSERT_EQ(result.classical, 2U);
  // The bar is the baseline with the lower ζ_p + ζ_v on these tracks.
  const auto score = [&](std::size_t i) {
    return result.filters[i].zeta_p + result.filters[i].zeta_v;
  };
  EXPECT_EQ(result.bar, score(1) < score(0) ? 1U : 0U);
  // No evaluation folder vouches for the candidate: it is ranked but held out, a finding.
  EXPECT_FALSE(result.eligible(2));
  EXPECT_NE(result.choice.winner, 2U);
  bool held_finding = false;
  for (const std::string& finding : result.findings) {
    held_finding |= finding.find("is held out of the choice") != std::string::npos;
  }
  EXPECT_TRUE(held_finding);

  EXPECT_EQ(evaluation::report_rank(result, options), result.exit_code());
  const nlohmann::json tracker = read_json(options.out / "tracker.json");
  EXPECT_EQ(tracker["tracker"], result.ranked[result.choice.winner].name);
  EXPECT_EQ(tracker["bar"], result.ranked[result.bar].name);
  ASSERT_EQ(tracker["ranking"].size(), 3U);
  for (const nlohmann::json& row : tracker["ranking"]) {
    const FilterOutcome& f = result.filter(row["filter"].get<std::string>());
    EXPECT_EQ(row["zeta_p"].get<double>(), f.zeta_p);
    EXPECT_EQ(row["zeta_v"].get<double>(), f.zeta_v);
  }
  EXPECT_EQ(tracker["findings"].get<std::vector<std::string>>(), result.findings);
}

}  // namespace
}  // namespace imm::testing
