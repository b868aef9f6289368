// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>

#include <fstream>

#include "imm/datasets/sha256.hpp"
#include "imm/datasets/track.hpp"
#include "imm/io/plain_imm_file.hpp"
#include "imm/support/config.hpp"
#include "imm/trainer/freeze.hpp"
#include "imm/trainer/nightly.hpp"
#include "imm/trainer/promote.hpp"
#include "imm/trainer/provenance.hpp"
#include "imm/trainer/registry.hpp"
#include "imm/trainer/wimm/wimm_trainer.hpp"
#include "testing/config_error.hpp"
#include "testing/temp_dir.hpp"

namespace imm::trainer {
namespace {

TEST(Freeze, WritesALoadableModelWithProvenanceAndMetrics) {
  const testing::TempDir dir;
  const auto out = dir / "sub" / "cv3.h5";
  const FreezeSummary summary = freeze_plain_imm({"configs/track/cv3_imm.toml", out, {}});
  EXPECT_EQ(summary.modes, 3);
  EXPECT_EQ(summary.state_dimension, 4);
  const io::ModelFileReader reader(out, io::kPlainImmKind);
  EXPECT_EQ(reader.provenance().config_toml, read_text_file("configs/track/cv3_imm.toml"));
  EXPECT_FALSE(reader.provenance().trainer_version.empty());
  EXPECT_EQ(io::read_plain_imm(reader).modes[2].process_noise, 1e-2);
  const std::string metrics = testing::slurp_text(metrics_path(out));
  EXPECT_NE(metrics.find("\"modes\": 3"), std::string::npos) << metrics;
}

// The config's `units` go into the file (every length of cv3_imm.toml is in km), and a regime in
// other units is refused naming the key.
TEST(Freeze, RecordsTheConfigsLengthUnitAndRefusesARegimeInAnother) {
  const testing::TempDir dir;
  (void)freeze_plain_imm({"configs/track/cv3_imm.toml", dir / "km.h5", {}});
  EXPECT_EQ(io::ModelFileReader(dir / "km.h5").provenance().length_unit, "km");
  (void)freeze_plain_imm(
      {"configs/track/cv3_imm.toml", dir / "r.h5", "configs/regimes/paper/ga_imm_table3.toml"});
  EXPECT_EQ(io::ModelFileReader(dir / "r.h5").provenance().regime_name, "ga_imm_table3");
  std::string metres = read_text_file("configs/track/cv3_imm.toml");
  metres.replace(metres.find("units = \"km\""), 12, "units = \"m\" ");
  testing::write_text(dir / "m.toml", metres);
  (void)freeze_plain_imm({dir / "m.toml", dir / "m.h5", {}});
  EXPECT_EQ(io::ModelFileReader(dir / "m.h5").provenance().length_unit, "m");
  try {
    (void)freeze_plain_imm(
        {dir / "m.toml", dir / "x.h5", "configs/regimes/paper/ga_imm_table3.toml"});
    ADD_FAILURE() << "a metres config frozen for a km regime";
  } catch (const support::ConfigError& error) {
    EXPECT_EQ(error.key(), "units");
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "x.h5"));
}

TEST(Freeze, BadConfigLeavesNoModelBehind) {
  const testing::TempDir dir;
  testing::write_text(dir / "bad.toml", "sample_period = 1.0\n");
  EXPECT_THROW((void)freeze_plain_imm({dir / "bad.toml", dir / "m.h5", {}}), support::ConfigError);
  EXPECT_FALSE(std::filesystem::exists(dir / "m.h5"));
}

TEST(Nightly, PlanListsStagesInPipelineOrder) {
  const NightlyPlan plan = load_nightly_plan("configs/nightly.toml");
  ASSERT_GE(plan.stages.size(), 4u);
  std::vector<std::string> kinds;
  for (const auto& stage : plan.stages) kinds.push_back(stage.kind);
  EXPECT_TRUE(std::is_sorted(kinds.begin(), kinds.end(), [](const auto& a, const auto& b) {
    auto rank = [](const std::string& k) {
      return k == "data" ? 0 : k == "model" ? 1 : k == "track" ? 2 : 3;
    };
    return rank(a) < rank(b);
  }));
  EXPECT_EQ(plan.stages.front().executable, "imm-data");
}

TEST(Nightly, UnknownKeyInThePlanIsAnError) {
  const testing::TempDir dir;
  testing::write_text(
      dir / "n.toml",
      "[[models]]\nname = \"a\"\ncommand = \"freeze\"\nconfig = \"c\"\nout = \"models/o\"\n"
      "threads = 2\n");
  try {
    (void)load_nightly_plan(dir / "n.toml");
    FAIL();
  } catch (const support::ConfigError& error) {
    EXPECT_EQ(error.key(), "models[0].threads");
  }
}

TEST(Nightly, AnEvaluationMustNameAModelStage) {
  const testing::TempDir dir;
  testing::write_text(dir / "n.toml",
                      "[[models]]\nname = \"a\"\ncommand = \"freeze\"\nconfig = \"c\"\n"
                      "out = \"models/a.h5\"\n[[evaluations]]\nexperiment = \"plain-imm\"\n"
                      "model = \"b\"\nout = \"r/\"\n");
  try {
    (void)load_nightly_plan(dir / "n.toml");
    FAIL();
  } catch (const support::ConfigError& error) {
    EXPECT_EQ(error.key(), "evaluations[0].model");
  }
}

TEST(Nightly, AModelMustBeWrittenInsideTheRegistry) {
  const testing::TempDir dir;
  testing::write_text(dir / "n.toml",
                      "[[models]]\nname = \"a\"\ncommand = \"freeze\"\nconfig = \"c\"\n"
                      "out = \"elsewhere/a.h5\"\n");
  try {
    (void)load_nightly_plan(dir / "n.toml");
    FAIL();
  } catch (const support::ConfigError& error) {
    EXPECT_EQ(error.key(), "models[0].out");
  }
}

TEST(Nightly, EvaluationsFollowTheirModel) {
  const NightlyPlan plan = load_nightly_plan("configs/nightly.toml");
  for (const auto& stage : plan.stages) {
    if (stage.kind != "model") continue;
    for (const NightlyStage* e : plan.evaluations_of(stage.name)) {
      ASSERT_TRUE(e->model_argument.has_value());
      EXPECT_EQ(e->arguments[*e->model_argument], stage.out.string());
    }
  }
}

// The morning report shows the last `make bench` medians and flags the ones > 10 % slower.
TEST(Nightly, MorningReportShowsBenchmarksAndFlagsSlowdowns) {
  testing::TempDir dir;
  const auto bench = dir.path() / "reports" / "bench";
  std::filesystem::create_directories(bench);
  std::ofstream(bench / "latest.json") << R"({"generated": "2026-11-23T01:00:00Z",
    "previous_run": "2026-11-22T01:00:00Z", "benchmarks": [
    {"name": "BM_W1_PlainImmStep", "median": 560.0, "unit": "ns", "previous": 500.0,
     "change": 0.12, "slower": true},
    {"name": "BM_W3_FuzzyCMeans1d", "median": 0.57, "unit": "ms", "previous": 0.58,
     "change": -0.017, "slower": false}]})";
  const auto night = dir.path() / "reports" / "nightly" / "2026-11-23";
  write_morning_report(night, NightlyPlan{}, NightlyResult{});
  std::ifstream in(night / "index.md");
  const std::string md((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(md.find("| BM_W1_PlainImmStep | 560 ns | 500 ns | +12 % ⚠ |"), std::string::npos) << md;
  EXPECT_NE(md.find("| BM_W3_FuzzyCMeans1d | 0.57 ms | 0.58 ms | -2 % |"), std::string::npos) << md;
}

std::string wimm_config_error(const std::string& text) {
  return testing::config_error_key("regime = \"configs/regimes/paper/wimm_training.toml\"\n" + text,
                                   [](const auto& path) { return wimm::load_wimm_config(path); });
}

TEST(WimmConfig, InvalidValuesAreNamed) {
  EXPECT_EQ(wimm_config_error("[tuning]\nalpha_range = [0.0, 1.0]\n"), "tuning.alpha_range");
  EXPECT_EQ(wimm_config_error("[filter]\nfusion = \"strong\"\n"), "filter.fusion");
  EXPECT_EQ(wimm_config_error("[filter]\nalpha = 1.5\n"), "filter.alpha");
  EXPECT_EQ(wimm_config_error("[training]\ntrajectories = 3\n"), "training");  // now the regime's
  EXPECT_EQ(wimm_config_error(""), "");
  const auto shipped = wimm::load_wimm_config("configs/wimm.toml");
  EXPECT_EQ(shipped.filter.threshold, 0.7);
  EXPECT_EQ(shipped.filter.alpha, 0.5);
  EXPECT_EQ(shipped.filter.sample_period, 2.0);
}

// The training tracks are not seed 004's: the random geometry of the training regime, seeded and
// reproducible, with T and the sensor taken into the filter.
TEST(WimmTraining, TracksComeFromTheConfigsRegime) {
  const auto config = wimm::load_wimm_config("configs/wimm.toml");
  EXPECT_EQ(config.regime.name, "wimm_training");
  EXPECT_EQ(config.filter.sample_period, config.regime.sample_period);
  EXPECT_EQ(config.filter.range_sigma, config.regime.sensor.noise.sigma(0));
  const auto a = datasets::draw_split(config.regime, datasets::Split::kTraining, 0, 5);
  const auto b = datasets::draw_split(config.regime, datasets::Split::kTraining, 0, 5);
  ASSERT_EQ(a.tracks.size(), 5u);
  EXPECT_EQ(a.tracks[3].plots, b.tracks[3].plots);
  EXPECT_NE(a.tracks[0].truth.row(0), a.tracks[1].truth.row(0));
  EXPECT_GT(std::hypot(a.tracks[2].truth(0, 0), a.tracks[2].truth(0, 3)), 79e3);
}

}  // namespace
}  // namespace imm::trainer

namespace imm::trainer {
namespace {

std::string bytes_of(const std::filesystem::path& path) { return testing::slurp_text(path); }

// A process killed between the manifest's rename (the commit point) and the shipped file's
// rename leaves the new manifest beside the old file; the next registry operation (every nightly
// starts with repair()) makes the file the manifest's, byte for byte, from the archive.
TEST(Registry, RepairMakesTheShippedFilesTheManifests) {
  const testing::TempDir dir;
  const auto models = dir / "models";
  const auto first = dir / "first.h5", second = dir / "second.h5";
  (void)freeze_plain_imm({"configs/track/cv3_imm.toml", first, {}});
  testing::write_text(dir / "cv3.toml", "# another text, the same filter\n" +
                                            read_text_file("configs/track/cv3_imm.toml"));
  (void)freeze_plain_imm({dir / "cv3.toml", second, {}});
  ASSERT_NE(bytes_of(first), bytes_of(second));
  std::filesystem::create_directories(models);
  {
    Registry registry(models);
    RegistryEntry entry = describe_model(first, dir.path(), "cv3");
    entry.file = "cv3.h5";
    registry.promote(entry, first);
    entry = describe_model(second, dir.path(), "cv3");
    entry.file = "cv3.h5";
    registry.promote(entry, second);
    EXPECT_EQ(bytes_of(models / "cv3.h5"), bytes_of(second));
    ASSERT_EQ(registry.find("cv3")->history.size(), 1u);
  }
  // The crash: the manifest names the second model, the old bytes are still shipped.
  std::filesystem::copy_file(first, models / "cv3.h5",
                             std::filesystem::copy_options::overwrite_existing);
  Registry registry(models);
  EXPECT_EQ(registry.repair(), std::vector<std::string>{"cv3.h5"});
  EXPECT_EQ(bytes_of(models / "cv3.h5"), bytes_of(second));
  EXPECT_TRUE(registry.repair().empty());
  // Rollback restores the first byte for byte, and the manifest says so after a reload.
  (void)registry.rollback("cv3");
  EXPECT_EQ(bytes_of(models / "cv3.h5"), bytes_of(first));
  EXPECT_EQ(Registry(models).find("cv3")->sha256, datasets::file_sha256_hex(first));
}

// The plain IMM of configs/track/cv3_imm.toml written with the given trainer version.
void write_cv3_stamped(const std::filesystem::path& out, const std::string& trainer_version,
                       const testing::TempDir& dir) {
  const auto frozen = dir / "frozen.h5";
  (void)freeze_plain_imm({"configs/track/cv3_imm.toml", frozen, {}});
  const io::ModelFileReader reader(frozen);
  io::Provenance provenance = reader.provenance();
  provenance.trainer_version = trainer_version;
  io::ModelFileWriter writer(out, provenance);
  io::write_plain_imm(writer, io::read_plain_imm(reader));
  writer.commit();
}

// imm-train promote: a deliberate promotion past the gates ships the file with its reason in the
// manifest; a file from uncommitted code, an empty reason or a file that does not read are refused
// and leave the registry as it was.
TEST(Registry, PromotionByHandRecordsItsReasonAndRefusesUncommittedCode) {
  const testing::TempDir dir;
  const auto models = dir / "models";
  std::filesystem::create_directories(models);
  const auto clean = dir / "clean.h5", dirty = dir / "dirty.h5";
  write_cv3_stamped(clean, "f92683f", dir);
  write_cv3_stamped(dirty, "f92683f-dirty", dir);

  const auto refused = [&](const PromoteOptions& options, const std::string& expected) {
    try {
      (void)promote_by_hand(options);
      ADD_FAILURE() << "promoted " << options.file;
    } catch (const std::exception& error) {
      EXPECT_NE(std::string(error.what()).find(expected), std::string::npos) << error.what();
    }
    EXPECT_FALSE(std::filesystem::exists(models / "cv3.h5"));
  };
  refused({dirty, "cv3", "schema 2", models}, "uncommitted code");
  refused({clean, "cv3", "  ", models}, "--reason");
  testing::write_text(dir / "broken.h5", "not a model");
  refused({dir / "broken.h5", "cv3", "schema 2", models}, "broken.h5");

  const RegistryEntry entry = promote_by_hand({clean, "cv3", "schema 2 rewrite", models});
  EXPECT_EQ(entry.file, "cv3.h5");
  EXPECT_EQ(bytes_of(models / "cv3.h5"), bytes_of(clean));
  const Registry reloaded(models);
  ASSERT_NE(reloaded.find("cv3"), nullptr);
  EXPECT_EQ(reloaded.find("cv3")->promotion_reason, "schema 2 rewrite");
  EXPECT_EQ(reloaded.find("cv3")->trainer_version, "f92683f");
}

TEST(Registry, AHostileManifestIsRefusedNamingTheField) {
  const testing::TempDir dir;
  testing::write_text(dir / "manifest.json",
                      R"({"manifest_version": 1, "models": [{"name": "a", "kind": "plain_imm",
                      "regime": {"name": "", "digest": ""}, "file": "../../etc/passwd",
                      "sha256": "x", "schema_version": 1, "trainer_version": "v",
                      "config_digest": "", "trained_utc": ""}]})");
  try {
    Registry registry(dir.path());
    FAIL();
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("models[0]: file"), std::string::npos) << error.what();
  }
}

}  // namespace
}  // namespace imm::trainer
