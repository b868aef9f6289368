// SPDX-License-Identifier: Apache-2.0
#include "imm/io/model_file.hpp"

#include <gtest/gtest.h>
#include <hdf5.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <limits>

#include "imm/io/ga_fuzzy_imm_file.hpp"
#include "imm/io/plain_imm_file.hpp"
#include "testing/hdf5_edit.hpp"
#include "testing/matrix_checks.hpp"
#include "testing/temp_dir.hpp"

namespace imm::io {
namespace {

PlainImmSpec example_spec() {
  PlainImmSpec spec;
  spec.sample_period = 2.0;
  spec.modes = {{"cv", MotionKind::kConstantVelocity, 2.0},
                {"turn", MotionKind::kConstantVelocity, 50.0, NoiseForm::kContinuous},
                {"singer", MotionKind::kSinger, 0.0, NoiseForm::kPiecewiseConstant, 20.0, 5.0}};
  spec.transition.resize(3, 3);
  spec.transition << 0.9, 0.05, 0.05, 0.1, 0.8, 0.1, 0.02, 0.08, 0.9;
  spec.initial_probabilities = Eigen::Vector3d(0.5, 0.25, 0.25);
  spec.measurement.kind = MeasurementKind::kPolar;
  spec.measurement.covariance << 2500.0, 0.0, 0.0, 7.6e-5;
  spec.initialization.method = InitializationMethod::kExplicit;
  spec.initialization.state = Eigen::VectorXd::LinSpaced(6, 1.0, 6.0);
  spec.initialization.covariance = Eigen::VectorXd::LinSpaced(6, 1.0, 2.0).asDiagonal();
  return spec;
}

Provenance example_provenance() {
  Provenance provenance;
  provenance.model_kind = std::string(kPlainImmKind);
  provenance.trainer_version = "v0.1.0-3-gabcdef";
  provenance.seed = 1234;
  provenance.config_toml = "[filter]\nsample_period = 2.0\n";
  provenance.dataset_digest = "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855";
  provenance.training_metrics = {{"error", 0.25}, {"rules", 9.0}};
  provenance.validation_metrics = {{"error", 0.31}};
  return provenance;
}

std::filesystem::path write_example(const testing::TempDir& dir, const std::string& name = "m.h5") {
  auto path = dir / name;
  ModelFileWriter writer(path, example_provenance());
  write_plain_imm(writer, example_spec());
  writer.commit();
  return path;
}

TEST(ModelFile, RoundTripKeepsProvenanceAndParameters) {
  const testing::TempDir dir;
  const auto path = write_example(dir);
  const ModelFileReader reader(path, kPlainImmKind);
  EXPECT_EQ(reader.schema_version(), kBaseModelSchemaVersion);
  const Provenance& p = reader.provenance();
  const Provenance expected = example_provenance();
  EXPECT_EQ(p.model_kind, expected.model_kind);
  EXPECT_EQ(p.trainer_version, expected.trainer_version);
  EXPECT_EQ(p.seed, expected.seed);
  EXPECT_EQ(p.config_toml, expected.config_toml);
  EXPECT_EQ(p.dataset_digest, expected.dataset_digest);
  EXPECT_EQ(p.training_metrics, expected.training_metrics);
  EXPECT_EQ(p.validation_metrics, expected.validation_metrics);
  EXPECT_EQ(p.created_utc.size(), 20u);  // 2026-11-22T00:18:36Z

  const PlainImmSpec back = read_plain_imm(reader);
  const PlainImmSpec original = example_spec();
  ASSERT_EQ(back.modes.size(), original.modes.size());
  for (std::size_t i = 0; i < back.modes.size(); ++i) {
    EXPECT_EQ(back.modes[i].name, original.modes[i].name);
    EXPECT_EQ(back.modes[i].motion, original.modes[i].motion);
    EXPECT_EQ(back.modes[i].noise_form, original.modes[i].noise_form);
    EXPECT_EQ(back.modes[i].process_noise, original.modes[i].process_noise);
    EXPECT_EQ(back.modes[i].singer_tau, original.modes[i].singer_tau);
    EXPECT_EQ(back.modes[i].singer_sigma, original.modes[i].singer_sigma);
  }
  EXPECT_EQ(back.sample_period, original.sample_period);
  EXPECT_EQ(back.transition, original.transition);
  EXPECT_EQ(back.initial_probabilities, original.initial_probabilities);
  EXPECT_EQ(back.measurement.kind, original.measurement.kind);
  EXPECT_EQ(back.measurement.covariance, original.measurement.covariance);
  EXPECT_EQ(back.initialization.method, original.initialization.method);
  EXPECT_EQ(back.initialization.state, original.initialization.state);
  EXPECT_EQ(back.initialization.covariance, original.initialization.covariance);
}

// The filters built from the original spec and from the file are the same filter: identical
// outputs on identical plots.
TEST(ModelFile, FilterFromFileEqualsFilterFromSpec) {
  const testing::TempDir dir;
  auto a = build_plain_imm<6>(example_spec());
  auto b = build_plain_imm<6>(read_plain_imm(write_example(dir)));
  GaussianState<6> start;
  start.mean << 1e4, -50.0, 0.0, 2e4, 20.0, 0.0;
  start.covariance = Eigen::Matrix<double, 6, 1>(1e4, 100, 1, 1e4, 100, 1).asDiagonal();
  a.initialize(start);
  b.initialize(start);
  for (int k = 1; k <= 50; ++k) {
    const Vector<2> z(std::hypot(1e4 - 100.0 * k, 2e4 + 40.0 * k),
                      std::atan2(1e4 - 100.0 * k, 2e4 + 40.0 * k));
    ASSERT_EQ(a.step(z), StepStatus::kOk);
    ASSERT_EQ(b.step(z), StepStatus::kOk);
    ASSERT_EQ(a.estimate().mean, b.estimate().mean);
  }
}

using testing::edit_and_reseal;
using testing::replace_dataset;

template <class T>
void replace_attribute(hid_t file, const char* object, const char* name, hid_t type, T value) {
  testing::set_attribute(file, object, name, type, &value);
}

struct Drill {
  std::string name;
  std::function<void(hid_t)> edit;
  std::string expected_field;
  std::string expected_text;
};

void PrintTo(const Drill& drill, std::ostream* out) { *out << drill.name; }

class HostileModelFile : public ::testing::TestWithParam<Drill> {};

TEST_P(HostileModelFile, IsRefusedWithFileAndField) {
  const Drill& drill = GetParam();
  const testing::TempDir dir;
  const auto path = write_example(dir);
  edit_and_reseal(path, drill.edit);
  try {
    (void)read_plain_imm(path);
    FAIL() << "accepted: " << drill.name;
  } catch (const FileError& error) {
    EXPECT_EQ(error.file(), path.string());
    EXPECT_EQ(error.field(), drill.expected_field) << error.what();
    EXPECT_NE(std::string(error.what()).find(drill.expected_text), std::string::npos)
        << error.what();
  }
}

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

INSTANTIATE_TEST_SUITE_P(
    Drills, HostileModelFile,
    ::testing::Values(
        Drill{"missing dataset", [](hid_t f) { H5Ldelete(f, "/imm/transition", H5P_DEFAULT); },
              "/imm/transition", "missing dataset"},
        Drill{"wrong shape",
              [](hid_t f) {
                replace_dataset(f, "/imm/transition", {2, 3}, {0.5, 0.5, 0, 0.5, 0.5, 0});
              },
              "/imm/transition", "expected shape 3x3, found 2x3"},
        Drill{"NaN transition",
              [](hid_t f) {
                replace_dataset(f, "/imm/transition", {3, 3},
                                {0.9, 0.05, 0.05, kNan, 0.8, 0.1, 0.02, 0.08, 0.9});
              },
              "/imm/transition", "entry (1, 0) = nan is not finite"},
        Drill{"rows not stochastic",
              [](hid_t f) {
                replace_dataset(f, "/imm/transition", {3, 3},
                                {0.9, 0.05, 0.05, 0.5, 0.8, 0.1, 0.02, 0.08, 0.9});
              },
              "/imm/transition", "row 1 sums to"},
        Drill{"NaN covariance",
              [](hid_t f) {
                replace_dataset(f, "/measurement/covariance", {2, 2}, {1.0, 0.0, 0.0, kNan});
              },
              "/measurement/covariance", "is not finite"},
        Drill{"rank 3",
              [](hid_t f) {
                replace_dataset(f, "/imm/initial_probabilities", {1, 1, 3}, {0.5, 0.25, 0.25});
              },
              "/imm/initial_probabilities", "expected a vector"},
        Drill{"negative noise",
              [](hid_t f) {
                replace_attribute(f, "/imm/modes/mode1", "process_noise", H5T_NATIVE_DOUBLE, -1.0);
              },
              "/imm/modes/mode1@process_noise", "not non-negative"},
        Drill{"infinite sigma",
              [](hid_t f) {
                replace_attribute(f, "/imm/modes/mode2", "sigma_a", H5T_NATIVE_DOUBLE,
                                  std::numeric_limits<double>::infinity());
              },
              "/imm/modes/mode2@sigma_a", "value inf is not finite"},
        Drill{"mode count too large",
              [](hid_t f) {
                replace_attribute(f, "/imm", "mode_count", H5T_NATIVE_INT64, std::int64_t{1000});
              },
              "/imm@mode_count", "outside [1, 16]"},
        Drill{"newer schema",
              [](hid_t f) {
                replace_attribute(f, "/", "schema_version", H5T_NATIVE_INT64,
                                  std::int64_t{kModelSchemaVersion + 1});
              },
              "/@schema_version", "newer than this reader supports"},
        Drill{"wrong kind",
              [](hid_t f) { testing::set_text_attribute(f, "/", "model_kind", "wimm"); },
              "/@model_kind", "expected 'plain_imm'"},
        Drill{"number where text belongs",
              [](hid_t f) {
                replace_attribute(f, "/imm/modes/mode0", "motion", H5T_NATIVE_DOUBLE, 1.0);
              },
              "/imm/modes/mode0@motion", "expected text"}),
    [](const ::testing::TestParamInfo<Drill>& param_info) {
      std::string name = param_info.param.name;
      for (char& c : name) {
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
      }
      return name;
    });

// A ga_fuzzy_imm file whose rule table has σ ≤ 0 or w < 0, behind a valid checksum.
TEST(GaFuzzyImmModelFile, HostileRuleTablesAreRefusedNamingTheField) {
  const testing::TempDir dir;
  const auto path = dir / "fuzzy.h5";
  GaFuzzyImmSpec spec;
  spec.settings.sample_period = 1.0;
  spec.levels = {
      {"u0.01", 0.01, FuzzyRuleTable({{0.0, 1.0, 0.0, 1.0, 1e-4}, {0.5, 0.3, 0.1, 2.0, 2e-4}})}};
  {
    Provenance provenance;
    provenance.model_kind = std::string(kGaFuzzyImmKind);
    ModelFileWriter writer(path, provenance);
    write_ga_fuzzy_imm(writer, spec);
    writer.commit();
  }
  const auto bytes = testing::read_bytes(path);
  const std::vector<std::pair<std::vector<double>, std::string>> drills = {
      {{0.0, 1.0, 0.0, 1.0, 1e-4, 0.5, -0.3, 0.1, 2.0, 2e-4},
       "rule 1: sigma1 and sigma2 must be positive"},
      {{0.0, 1.0, 0.0, 1.0, -1e-4, 0.5, 0.3, 0.1, 2.0, 2e-4}, "rule 0: w must be non-negative"},
      {{0.0, 1.0, 0.0, 1.0, 1e-4, 0.5, 0.3, kNan, 2.0, 2e-4}, "is not finite"}};
  for (const auto& drill : drills) {
    const std::vector<double>& values = drill.first;
    const std::string& message = drill.second;
    testing::write_bytes(path, bytes);
    edit_and_reseal(path, [&](hid_t f) {
      replace_dataset(f, "/ga_fuzzy_imm/level0/rules", {2, 5}, values);
    });
    try {
      (void)read_ga_fuzzy_imm(path);
      FAIL() << message;
    } catch (const FileError& error) {
      EXPECT_EQ(error.field(), "/ga_fuzzy_imm/level0/rules") << error.what();
      EXPECT_NE(std::string(error.what()).find(message), std::string::npos) << error.what();
    }
  }
  testing::write_bytes(path, bytes);
  edit_and_reseal(path, [&](hid_t f) {
    replace_dataset(f, "/ga_fuzzy_imm/level0/rules", {51, 5}, std::vector<double>(255, 1.0));
  });
  EXPECT_THROW((void)read_ga_fuzzy_imm(path), FileError);
}

TEST(ModelFile, FlippedDataByteIsCaughtBeforeUse) {
  const testing::TempDir dir;
  const auto path = write_example(dir);
  auto bytes = testing::read_bytes(path);
  // Find the stored 2500.0 of R (little-endian IEEE 754) and change one bit of its mantissa.
  const double needle = 2500.0;
  const char* raw = reinterpret_cast<const char*>(&needle);
  const auto found = std::search(bytes.begin() + 512, bytes.end(), raw, raw + sizeof needle);
  ASSERT_NE(found, bytes.end());
  *found = static_cast<char>(*found ^ 0x01);
  testing::write_bytes(path, bytes);
  EXPECT_THROW((void)read_plain_imm(path), FileError);
}

TEST(ModelFile, DataSetContainerIsNotAModel) {
  const testing::TempDir dir;
  const auto path = dir / "data.h5";
  ContainerWriter writer(path, "immtrain-dataset");
  writer.commit();
  EXPECT_THROW(ModelFileReader{path}, FileError);
}

TEST(ModelFile, EmptyKindIsRefusedByTheWriter) {
  const testing::TempDir dir;
  EXPECT_THROW(ModelFileWriter(dir / "x.h5", Provenance{}), FileError);
}

// One rule for every number and every name in a model file, whether a loader reads it or not:
// the GA levels' metadata and the MLP's training curve are held to it like the parameters, and
// units and column names to the grammar docs/model-schema.md states. Each edit of a shipped model
// (resealed, so it reaches the reader) is refused naming the field.
TEST(ModelFileReader, MetadataUnitsAndNamesFollowTheSchemaRules) {
  struct Edit {
    std::string model, field, expected;
    std::function<void(hid_t)> apply;
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const std::vector<Edit> edits = {
      {"ga_fuzzy_imm_agile_air.h5", "/ga_fuzzy_imm/level0@validation_error", "is not finite",
       [&](hid_t f) {
         testing::set_attribute(f, "/ga_fuzzy_imm/level0", "validation_error", H5T_NATIVE_DOUBLE,
                                &nan);
       }},
      {"ga_fuzzy_imm_agile_air.h5", "/ga_fuzzy_imm/level1@wall_seconds", "is not finite",
       [&](hid_t f) {
         testing::set_attribute(f, "/ga_fuzzy_imm/level1", "wall_seconds", H5T_NATIVE_DOUBLE, &inf);
       }},
      {"ga_fuzzy_imm_agile_air.h5", "/ga_fuzzy_imm/level0@generations", "negative",
       [](hid_t f) {
         const std::int64_t count = -3;
         testing::set_attribute(f, "/ga_fuzzy_imm/level0", "generations", H5T_NATIVE_INT64, &count);
       }},
      {"mlp_input_estimator.h5", "/training/loss", "entry (2, 1) = nan is not finite",
       [&](hid_t f) {
         std::vector<double> loss(121 * 3, 1.0);
         loss[2 * 3 + 1] = nan;
         testing::replace_dataset(f, "/training/loss", {121, 3}, loss);
         testing::set_text_attribute(f, "/training/loss", "columns",
                                     "epoch,training_mse,validation_mse");
         testing::set_text_attribute(f, "/training/loss", "units", "1");
       }},
      {"ga_fuzzy_imm_agile_air.h5", "/ga_fuzzy_imm/level0@units", "is not name=unit",
       [](hid_t f) {
         testing::set_text_attribute(f, "/ga_fuzzy_imm/level0", "units",
                                     "maneuver_level=km^2.s^4,fitness=1,error=1,"
                                     "validation_error=1,wall_seconds=s");
       }},
      {"mlp_input_estimator.h5", "/training/loss@columns", "column name 'epoch\\x07'",
       [](hid_t f) {
         testing::set_text_attribute(f, "/training/loss", "columns",
                                     "epoch\a,training_mse,validation_mse");
       }},
  };
  for (const Edit& edit : edits) {
    const testing::TempDir dir;
    const auto path = dir / edit.model;
    std::filesystem::copy_file(std::filesystem::path("models") / edit.model, path);
    (void)ModelFileReader(path);  // the shipped file reads
    testing::edit_and_reseal(path, edit.apply);
    try {
      (void)ModelFileReader(path);
      FAIL() << "accepted: " << edit.field;
    } catch (const FileError& error) {
      EXPECT_EQ(error.field(), edit.field) << error.what();
      EXPECT_NE(std::string(error.what()).find(edit.expected), std::string::npos) << error.what();
    }
  }
}

}  // namespace
}  // namespace imm::io
