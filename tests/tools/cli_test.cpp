// SPDX-License-Identifier: Apache-2.0
// The command line keeps the README's promises: every tool prints its version, usage errors exit
// 1 with one readable line (a mistyped subcommand gets the closest match, a range error names the
// bound), --help shows defaults, imm-data creates its output folder, and imm-track runs every
// shipped model kind and writes every number so that it reads back to the same double.

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <charconv>
#include <fstream>
#include <set>
#include <sstream>

#include "imm/io/tsk_sensor_file.hpp"
#include "imm/load.hpp"
#include "imm/version.hpp"
#include "testing/kind_filters.hpp"
#include "testing/run_tool.hpp"
#include "testing/shipped_models.hpp"
#include "testing/temp_dir.hpp"

namespace imm {
namespace {

using testing::run_tool;

const std::vector<std::string> kTools = {"imm-train", "imm-eval", "imm-data", "imm-inspect",
                                         "imm-track"};

TEST(CommandLine, EveryToolPrintsItsVersion) {
  for (const std::string& tool : kTools) {
    const auto result = run_tool(tool, {"--version"}, testing::source_root());
    EXPECT_EQ(result.exit_code, 0) << tool << ": " << result.err;
    const std::string expected =
        tool + " " + kVersion + " (model schema " + std::to_string(kModelSchemaVersion) + ", git ";
    EXPECT_EQ(result.out.rfind(expected, 0), 0u) << result.out;
  }
}

struct UsageCase {
  std::string tool;
  std::vector<std::string> arguments;
  std::string message;  ///< expected on stderr
};

TEST(CommandLine, UsageErrorsExitOneWithAReadableMessage) {
  const std::vector<UsageCase> cases = {
      {"imm-train", {"gaa"}, "imm-train: unknown command 'gaa'; did you mean 'ga'?"},
      {"imm-train", {"tks", "--config", "x"}, "unknown command 'tks'; did you mean 'tsk'?"},
      {"imm-eval", {"fimn"}, "imm-eval: unknown command 'fimn'; did you mean 'fimm'?"},
      {"imm-eval", {"input-estimater"}, "did you mean 'input-estimator'?"},
      {"imm-data", {"trakcs"}, "imm-data: unknown command 'trakcs'; did you mean 'tracks'?"},
      {"imm-train", {"zebra"}, "imm-train: unknown command 'zebra'\n"},  // nothing close
      {"imm-train", {"ga", "--threads", "0"}, "imm-train: --threads: must be in [1, 1024] (got 0)"},
      {"imm-train",
       {"ga", "--threads", "1000000"},
       "--threads: must be in [1, 1024] (got 1000000)"},
      {"imm-data",
       {"import", "--out", "o.h5", "--sample-period", "nan", "r.csv"},
       "--sample-period: must be in [1e-06, 36000] s (got nan)"},
      {"imm-data",
       {"import", "--out", "o.h5", "--tolerance", "nan", "r.csv"},
       "--tolerance: must be in [1e-09, 0.49] (got nan)"},
      {"imm-eval", {"plain-imm", "--runs", "-3"}, "--runs: must be ≥ 1 (got -3)"},
      {"imm-data",
       {"tracks", "--regime", "r", "--out", "o", "--count", "0"},
       "--count: must be in [1, 1000000] (got 0)"},
      // A seed is a whole number in [0, 2⁶⁴ − 1]: "-1" and 2⁶⁴ were read as 2⁶⁴ − 1.
      {"imm-data",
       {"tracks", "--regime", "r", "--out", "o", "--seed", "-1"},
       "--seed: must be a whole number in [0, 18446744073709551615] (got -1)"},
      {"imm-train",
       {"ga", "--seed", "18446744073709551616"},
       "--seed: must be a whole number in [0, 18446744073709551615] (got 18446744073709551616)"},
      {"imm-eval", {"multi-target", "--seed", "1e3"}, "(got 1e3)"},
      {"imm-track", {"--measurements", "m.csv"}, "imm-track: --filter is required"},
      {"imm-inspect", {}, "imm-inspect: file is required"},
      {"imm-track", {"--filter", "f", "--measurements", "m", "--bogus"}, "--bogus"},
  };
  for (const UsageCase& c : cases) {
    const auto result = run_tool(c.tool, c.arguments, testing::source_root());
    EXPECT_EQ(result.exit_code, 1) << c.tool << " " << c.message << ": " << result.err;
    EXPECT_NE(result.err.find(c.message), std::string::npos) << result.err;
    EXPECT_NE(result.err.find("Run with --help"), std::string::npos) << result.err;
  }
}

TEST(CommandLine, HelpShowsTheDefaults) {
  const auto track = run_tool("imm-track", {"--help"}, testing::source_root());
  EXPECT_EQ(track.exit_code, 0);
  EXPECT_NE(track.out.find("--max-gap INT:≥ 1=50"), std::string::npos) << track.out;
  const auto tsk = run_tool("imm-train", {"tsk", "--help"}, testing::source_root());
  EXPECT_EQ(tsk.exit_code, 0);
  EXPECT_NE(tsk.out.find("--config TEXT=configs/tsk_range_sensor.toml"), std::string::npos)
      << tsk.out;
}

// A command named after a model kind answers to the kind's own name (imm/model_kinds.hpp), with the
// same options; a name no kind or command has is still a usage error.
TEST(CommandLine, KindCommandsAnswerToTheirModelKindsNames) {
  const std::pair<const char*, std::vector<std::string>> cases[] = {
      {"imm-train", {"ga_fuzzy_imm", "--help"}}, {"imm-train", {"mlp_input_estimator", "--help"}},
      {"imm-train", {"fcm_imm", "--help"}},      {"imm-train", {"tsk_sensor", "--help"}},
      {"imm-eval", {"ga_fuzzy_imm", "--help"}},  {"imm-eval", {"tsk_sensor", "--help"}},
      {"imm-eval", {"plain_imm", "--help"}},     {"imm-eval", {"mlp_input_estimator", "--help"}}};
  for (const auto& [tool, arguments] : cases) {
    const auto result = run_tool(tool, arguments, testing::source_root());
    EXPECT_EQ(result.exit_code, 0) << tool << " " << arguments[0] << ": " << result.err;
    EXPECT_NE(result.out.find("--"), std::string::npos) << result.out;
  }
  const auto short_name = run_tool("imm-train", {"tsk", "--help"}, testing::source_root());
  const auto kind_name = run_tool("imm-train", {"tsk_sensor", "--help"}, testing::source_root());
  EXPECT_EQ(short_name.out.substr(short_name.out.find('\n')),
            kind_name.out.substr(kind_name.out.find('\n')));  // the same options
  EXPECT_EQ(run_tool("imm-train", {"no_such_kind"}, testing::source_root()).exit_code, 1);
}

TEST(CommandLine, ImmTrackNamesAMissingModelFile) {
  const auto result =
      run_tool("imm-track", {"--filter", "models/no_such.h5", "--measurements", "m"},
               testing::source_root());
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("models/no_such.h5: no such model file"), std::string::npos)
      << result.err;
}

TEST(CommandLine, ImmDataCreatesItsOutputFolder) {
  testing::TempDir dir;
  const auto out = dir.path() / "new" / "folder" / "test.h5";
  const auto csv = dir.path() / "other" / "plots.csv";
  const auto result = run_tool("imm-data",
                               {"tracks", "--regime", "configs/regimes/paper/ga_imm_table3.toml",
                                "--count", "1", "--out", out.string(), "--csv", csv.string()},
                               testing::source_root());
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_TRUE(std::filesystem::is_regular_file(out));
  EXPECT_TRUE(std::filesystem::is_regular_file(csv));
}

// Standard output that cannot be written (a full disk: /dev/full) is an error, exit 2 with a line
// on stderr: imm-inspect's JSON, imm-data's summary and imm-track's rows once went nowhere with
// exit 0.
TEST(CommandLine, OutputThatCannotBeWrittenIsAnError) {
  if (!std::filesystem::exists("/dev/full")) GTEST_SKIP() << "no /dev/full";
  testing::TempDir dir;
  const auto err = dir.path() / "err.txt";
  const auto exit_of = [&](const std::string& tool, const std::vector<std::string>& arguments) {
    const pid_t pid =
        testing::start_tool(tool, arguments, "/dev/full", err.string(), testing::source_root());
    EXPECT_GT(pid, 0) << tool;
    int status = 0;
    waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  };
  EXPECT_EQ(exit_of("imm-inspect", {"models/cv3_imm.h5", "--json"}), 2);
  EXPECT_NE(testing::slurp(err).find("imm-inspect: writing standard output failed"),
            std::string::npos)
      << testing::slurp(err);
  EXPECT_EQ(exit_of("imm-data", {"tracks", "--regime", "configs/regimes/paper/ga_imm_table3.toml",
                                 "--count", "1", "--out", (dir.path() / "t.h5").string()}),
            2);
  EXPECT_NE(testing::slurp(err).find("imm-data: writing standard output failed"),
            std::string::npos);
  testing::write_text(dir.path() / "plots.csv", "k,zx,zy\n0,1.0,2.0\n1,1.5,2.5\n2,2.0,3.0\n");
  EXPECT_EQ(exit_of("imm-track", {"--filter", "configs/track/cv3_imm.toml", "--measurements",
                                  (dir.path() / "plots.csv").string()}),
            2);
  EXPECT_NE(testing::slurp(err).find("imm-track: writing standard output failed"),
            std::string::npos);
}

// Every number of a row, parsed exactly (std::from_chars).
std::vector<double> numbers_of(const std::string& line) {
  std::vector<double> values;
  std::stringstream in(line);
  std::string field;
  std::getline(in, field, ',');  // k
  std::getline(in, field, ',');  // status
  while (std::getline(in, field, ',')) {
    double value = 0.0;
    const auto parsed = std::from_chars(field.data(), field.data() + field.size(), value);
    EXPECT_EQ(parsed.ptr, field.data() + field.size()) << field;
    values.push_back(value);
  }
  return values;
}

// imm-track over 60 plausible plots of each shipped model, against load_tracker in this process:
// the last row's numbers are the tracker's doubles, bit for bit.
TEST(CommandLine, ImmTrackRunsEveryShippedKindAndWritesNumbersLosslessly) {
  testing::TempDir dir;
  std::set<std::string> kinds;
  for (const auto& path : testing::shipped_models()) {
    SCOPED_TRACE(path.string());
    Tracker tracker = load_tracker(path);
    LoadedFilter loaded = load_filter(path);
    const bool polar = loaded.options.measurement_kind == MeasurementKind::kPolar;
    const auto csv = dir.path() / (path.stem().string() + ".csv");
    {
      std::ofstream out(csv);
      out << (polar ? "k,range,azimuth\n" : "k,zx,zy\n");
      out.precision(17);
      for (int k = 0; k < 60; ++k) {
        const Eigen::Vector2d z = testing::plausible_plot(loaded.options, k);
        out << k << ',' << z(0) << ',' << z(1) << '\n';
        (void)tracker.process(k, z);  // the same decimal text reads back to z: 17 digits
      }
    }
    const auto result =
        run_tool("imm-track", {"--filter", path.string(), "--measurements", csv.string()},
                 testing::source_root());
    ASSERT_EQ(result.exit_code, 0) << result.err;
    std::vector<std::string> lines;
    std::istringstream in(result.out);
    for (std::string line; std::getline(in, line);) lines.push_back(line);
    ASSERT_EQ(lines.size(), 61u);
    const std::vector<double> last = numbers_of(lines.back());
    const int n = tracker.state_dimension();
    Eigen::VectorXd mean(n), variance(n);
    tracker.state(mean, variance);
    const ModeVector mu = tracker.mode_probabilities();
    // …, the modes' probabilities, then the envelope test: the window's mean NIS and its flag.
    ASSERT_EQ(last.size(), static_cast<std::size_t>(2 * n + mu.size() + 2));
    EXPECT_EQ(last[last.size() - 2], tracker.envelope().mean());
    EXPECT_EQ(last.back(), tracker.envelope().outside() ? 1.0 : 0.0);
    for (int i = 0; i < n; ++i) {
      EXPECT_EQ(last[static_cast<std::size_t>(i)], mean(i)) << "state " << i;
      EXPECT_EQ(last[static_cast<std::size_t>(n + i)], variance(i)) << "variance " << i;
    }
    for (int j = 0; j < mu.size(); ++j) {
      EXPECT_EQ(last[static_cast<std::size_t>(2 * n + j)], mu(j)) << "mode " << j;
    }
    kinds.insert(loaded.provenance.model_kind);
  }
  EXPECT_EQ(kinds.size(), loadable_model_kinds().size());  // every kind is shipped and ran
}

}  // namespace
}  // namespace imm
