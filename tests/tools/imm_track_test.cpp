// SPDX-License-Identifier: Apache-2.0
// End-to-end: imm-track: tracking a measurement CSV with a model file or a config.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>

#include "testing/regime_files.hpp"
#include "testing/tools_fixture.hpp"

namespace imm {
namespace {

using testing::fields_of;
using testing::lines_of;
using testing::run_tool;
using testing::Tools;

TEST_F(Tools, ImmTrackReportsBadRowsAndKeepsTheFilterIntact) {
  // Corrupt scans 50 and 51 of a clean run.
  const auto clean_lines = lines_of(testing::slurp(dir_ / "plots.csv"));
  std::ofstream dirty(dir_ / "dirty.csv");
  std::size_t corrupted_line = 0;
  for (std::size_t i = 0; i < clean_lines.size(); ++i) {
    if (clean_lines[i].rfind("50,", 0) == 0) {
      dirty << "50,nan,1.0\n";
      corrupted_line = i + 1;
    } else if (clean_lines[i].rfind("51,", 0) == 0) {
      dirty << "51,2.0\n";
    } else {
      dirty << clean_lines[i] << '\n';
    }
  }
  dirty.close();
  const std::string filter = config("configs/track/cv3_imm.toml").string();
  const auto clean = run_tool(
      "imm-track", {"--filter", filter, "--measurements", (dir_ / "plots.csv").string()}, root_);
  const auto bad = run_tool(
      "imm-track", {"--filter", filter, "--measurements", (dir_ / "dirty.csv").string()}, root_);
  ASSERT_EQ(clean.exit_code, 0) << clean.err;
  ASSERT_EQ(bad.exit_code, 0) << bad.err;
  EXPECT_NE(bad.err.find("dirty.csv:" + std::to_string(corrupted_line) + ": zx is nan"),
            std::string::npos)
      << bad.err;
  EXPECT_NE(bad.err.find("dirty.csv:" + std::to_string(corrupted_line + 1) + ": expected 3 fields"),
            std::string::npos)
      << bad.err;

  const auto clean_rows = lines_of(clean.out);
  const auto bad_rows = lines_of(bad.out);
  ASSERT_EQ(clean_rows.size(), 161u);  // header + 160 scans
  ASSERT_EQ(bad_rows.size(), 161u);    // both bad rows name their scan: reported as rejected
  for (std::size_t i = 0; i <= 50; ++i) EXPECT_EQ(clean_rows[i], bad_rows[i]) << "row " << i;
  const auto before = fields_of(bad_rows[50]);  // scan 49
  for (std::size_t i : {51u, 52u}) {
    const auto rejected = fields_of(bad_rows[i]);
    EXPECT_EQ(rejected[0], std::to_string(i - 1));
    EXPECT_EQ(rejected[1], "rejected");
    EXPECT_EQ(std::vector<std::string>(rejected.begin() + 2, rejected.end()),
              std::vector<std::string>(before.begin() + 2, before.end()));
  }
  // Scan 52 predicts through 50 and 51 and then tracks on.
  const auto resumed = fields_of(bad_rows[53]);
  EXPECT_EQ(resumed[0], "52");
  EXPECT_EQ(resumed[1], "updated");
  EXPECT_NEAR(std::stod(resumed[2]), std::stod(fields_of(clean_rows[53])[2]), 1.0);
}

TEST_F(Tools, ImmTrackGivesTheSameTrackFromTheModelFileAsFromTheConfig) {
  const auto model = dir_ / "cv3.h5";
  freeze_cv3(model);
  const auto from_config = run_tool("imm-track",
                                    {"--filter", config("configs/track/cv3_imm.toml").string(),
                                     "--measurements", (dir_ / "plots.csv").string()},
                                    root_);
  const auto from_model = run_tool(
      "imm-track", {"--filter", model.string(), "--measurements", (dir_ / "plots.csv").string()},
      root_);
  ASSERT_EQ(from_model.exit_code, 0) << from_model.err;
  EXPECT_EQ(from_config.out, from_model.out);
}

// A write that fails (a full disk: /dev/full) is an error, exit 2, not a track cut short that exits
// 0 as it once did.
TEST_F(Tools, ImmTrackFailsWhenItsOutputCannotBeWritten) {
  if (!std::filesystem::exists("/dev/full")) GTEST_SKIP() << "no /dev/full";
  const auto full =
      run_tool("imm-track",
               {"--filter", config("configs/track/cv3_imm.toml").string(), "--measurements",
                (dir_ / "plots.csv").string(), "--out", "/dev/full"},
               root_);
  EXPECT_EQ(full.exit_code, 2) << full.err;
  EXPECT_NE(full.err.find("writing /dev/full failed"), std::string::npos) << full.err;
}

TEST_F(Tools, ImmTrackRefusesMismatchedMeasurements) {
  testing::write_text(dir_ / "polar.csv", "k,range,azimuth\n0,100,0.1\n");
  const auto result = run_tool("imm-track",
                               {"--filter", config("configs/track/cv3_imm.toml").string(),
                                "--measurements", (dir_ / "polar.csv").string()},
                               root_);
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("polar"), std::string::npos) << result.err;
}

// A CSV with a time column. The plain IMM takes times as they come: t = 100 + k T gives the k
// file's track to the bit (its first column t), and times 2.5 T apart a track of their own. A model
// of one sample period (the GA-fuzzy IMM's, 1 s) refuses times recorded at another period, naming
// the column, the line and its period, which stderr always states with the units (a CSV cannot say
// its own).
TEST_F(Tools, ImmTrackTakesATimeColumnAsTheModelAllows) {
  const auto model = dir_ / "cv3.h5";
  freeze_cv3(model);
  const auto lines = lines_of(testing::slurp(dir_ / "plots.csv"));
  ASSERT_GT(lines.size(), 10u);
  std::string timed = "t,zx,zy\n", stretched = "t,zx,zy\n";
  for (std::size_t i = 1; i < lines.size(); ++i) {
    const auto comma = lines[i].find(',');
    const double k = std::stod(lines[i].substr(0, comma));
    timed += std::to_string(100.0 + k) + lines[i].substr(comma) + "\n";
    stretched += std::to_string(2.5 * k) + lines[i].substr(comma) + "\n";
  }
  testing::write_text(dir_ / "timed.csv", timed);
  testing::write_text(dir_ / "stretched.csv", stretched);
  const auto run = [&](const std::filesystem::path& filter, const std::string& csv) {
    return run_tool("imm-track", {"--filter", filter.string(), "--measurements", csv}, root_);
  };
  // Every output line but its first column.
  const auto without_first_column = [&](const std::string& out) {
    std::vector<std::string> rest;
    for (const auto& line : lines_of(out)) rest.push_back(line.substr(line.find(',')));
    return rest;
  };
  const auto by_scan = run(model, (dir_ / "plots.csv").string());
  const auto by_time = run(model, (dir_ / "timed.csv").string());
  ASSERT_EQ(by_time.exit_code, 0) << by_time.err;
  EXPECT_EQ(by_time.out.substr(0, 2), "t,");
  EXPECT_EQ(lines_of(by_time.out)[1].substr(0, 4), "100,") << by_time.out.substr(0, 200);
  EXPECT_EQ(without_first_column(by_time.out), without_first_column(by_scan.out));
  EXPECT_NE(
      by_scan.err.find("sample period 1 s, lengths in km, Cartesian plots with σ = 0.5 km, 0.5 km"),
      std::string::npos)
      << by_scan.err;
  const auto slower = run(model, (dir_ / "stretched.csv").string());
  ASSERT_EQ(slower.exit_code, 0) << slower.err;
  EXPECT_EQ(lines_of(slower.out).size(), lines_of(by_scan.out).size());
  EXPECT_NE(slower.out, by_time.out);

  const auto learned = root_ / "models" / "ga_fuzzy_imm.h5";
  const auto refused = run(learned, (dir_ / "stretched.csv").string());
  EXPECT_EQ(refused.exit_code, 2);
  EXPECT_NE(refused.err.find("stretched.csv:3: column 't': 2.5 s is 2.5 s after the first plot"),
            std::string::npos)
      << refused.err;
  EXPECT_NE(refused.err.find("sample period 1 s"), std::string::npos) << refused.err;
  EXPECT_TRUE(refused.out.empty());
}

// imm-data export's CSV goes straight into imm-track: its truth columns (x, vx, y, vy) are carried
// along unread, so a track exported with them and without gives the same track to the byte.
TEST_F(Tools, ImmTrackTakesWhatImmDataExportWrites) {
  const auto export_to = [&](const std::string& folder, bool truth) {
    std::vector<std::string> args{"export",
                                  "--regime",
                                  config("configs/regimes/agile_air.toml").string(),
                                  "--count",
                                  "1",
                                  "--out-dir",
                                  (dir_ / folder).string()};
    if (!truth) args.emplace_back("--no-truth");
    const auto result = run_tool("imm-data", args, root_);
    EXPECT_EQ(result.exit_code, 0) << result.err;
    return dir_ / folder / "track_000.csv";
  };
  const auto with_truth = export_to("with_truth", true);
  const auto without = export_to("without", false);
  ASSERT_EQ(fields_of(lines_of(testing::slurp(with_truth))[0]).size(), 7u);
  const std::string model = (root_ / "models" / "classical_imm_agile_air.h5").string();
  const auto a =
      run_tool("imm-track", {"--filter", model, "--measurements", with_truth.string()}, root_);
  const auto b =
      run_tool("imm-track", {"--filter", model, "--measurements", without.string()}, root_);
  ASSERT_EQ(a.exit_code, 0) << a.err;
  ASSERT_EQ(b.exit_code, 0) << b.err;
  EXPECT_EQ(a.out, b.out);
  const auto rows = lines_of(a.out);
  ASSERT_GT(rows.size(), 100u);
  EXPECT_EQ(std::count_if(
                rows.begin(), rows.end(),
                [](const std::string& row) { return row.find(",updated,") != std::string::npos; }),
            static_cast<std::ptrdiff_t>(rows.size() - 3));  // the header, waiting, initialized
}

// The classical CV/CA/CT IMM from its config and from its frozen file: the same track, a state
// that ends with the turn rate ("omega"), and on a coordinated turn of 1.7 °/s seen every 5 s with
// 100 m plots an estimate of ω near the truth once the turn is under way.
TEST_F(Tools, ImmTrackRunsTheCoordinatedTurnImmAndEstimatesTheTurnRate) {
  const double T = 5.0, omega = 0.03, speed = 150.0;
  std::mt19937_64 rng(11);
  std::normal_distribution<double> noise(0.0, 100.0);
  std::string csv = "k,zx,zy\n";
  double x = 0.0, y = 0.0, heading = 0.0;
  for (int k = 0; k < 60; ++k) {
    const double turn = k < 10 ? 0.0 : omega;  // straight, then the turn
    if (turn == 0.0) {
      x += speed * T * std::cos(heading);
      y += speed * T * std::sin(heading);
    } else {
      x += speed / turn * (std::sin(heading + turn * T) - std::sin(heading));
      y += speed / turn * (std::cos(heading) - std::cos(heading + turn * T));
      heading += turn * T;
    }
    csv += std::to_string(k) + "," + std::to_string(x + noise(rng)) + "," +
           std::to_string(y + noise(rng)) + "\n";
  }
  testing::write_text(dir_ / "turn.csv", csv);
  const std::string filter = config("configs/track/cv_ca_ct_imm.toml").string();
  const auto tracked = run_tool(
      "imm-track", {"--filter", filter, "--measurements", (dir_ / "turn.csv").string()}, root_);
  ASSERT_EQ(tracked.exit_code, 0) << tracked.err;
  const auto rows = lines_of(tracked.out);
  ASSERT_EQ(rows.size(), 61U);
  const auto header = fields_of(rows[0]);
  const auto at = std::find(header.begin(), header.end(), "omega");
  ASSERT_NE(at, header.end()) << rows[0];
  EXPECT_EQ(header[2], "x");
  EXPECT_NE(std::find(header.begin(), header.end(), "mu_turn"), header.end()) << rows[0];
  const auto column = static_cast<std::size_t>(at - header.begin());
  double mean_omega = 0.0;
  for (int k = 45; k < 60; ++k) mean_omega += std::stod(fields_of(rows[k + 1])[column]) / 15.0;
  EXPECT_NEAR(mean_omega, omega, 0.01) << rows[60];

  const auto model = dir_ / "cv_ca_ct.h5";
  const auto frozen =
      run_tool("imm-train", {"freeze", "--config", filter, "--out", model.string()}, root_);
  ASSERT_EQ(frozen.exit_code, 0) << frozen.err;
  const auto from_model =
      run_tool("imm-track",
               {"--filter", model.string(), "--measurements", (dir_ / "turn.csv").string()}, root_);
  ASSERT_EQ(from_model.exit_code, 0) << from_model.err;
  EXPECT_EQ(from_model.out, tracked.out);
}

}  // namespace
}  // namespace imm
