// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/model_files/freeze.hpp"

#include <gtest/gtest.h>

#include <filesystem>

#include "imm/io/plain_imm_file.hpp"
#include "imm/support/config.hpp"
#include "imm/trainer/provenance.hpp"
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

}  // namespace
}  // namespace imm::trainer
