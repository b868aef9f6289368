// SPDX-License-Identifier: Apache-2.0
// Model-file schema versions (docs/model-schema.md): files of version 1 — one of every kind, kept
// in tests/data/schema_v1 as they were shipped — still read, and build the same filter, step for
// step to the bit, as the version-2 file written from what was read; a version-2 file describes
// itself (units on every dataset and on every group's real attributes, columns on every matrix,
// the length unit at the root), and a version-2 file whose description is missing or malformed is
// refused naming the field.

#include <gtest/gtest.h>
#include <hdf5.h>

#include <algorithm>
#include <string>

#include "imm/io/fcm_imm_file.hpp"
#include "imm/io/file_error.hpp"
#include "imm/io/ga_fuzzy_imm_file.hpp"
#include "imm/io/mlp_input_estimator_file.hpp"
#include "imm/io/model_file.hpp"
#include "imm/io/plain_imm_file.hpp"
#include "imm/io/tsk_sensor_file.hpp"
#include "imm/io/wimm_file.hpp"
#include "imm/load.hpp"
#include "imm/version.hpp"
#include "testing/hdf5_edit.hpp"
#include "testing/kind_filters.hpp"
#include "testing/run_tool.hpp"
#include "testing/temp_dir.hpp"

namespace imm {
namespace {

std::vector<std::filesystem::path> version1_files() {
  std::vector<std::filesystem::path> files;
  for (const auto& entry :
       std::filesystem::directory_iterator(testing::source_root() / "tests/data/schema_v1")) {
    if (entry.path().extension() == ".h5") files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

// What was read from `reader`, written again by the current writer (so: schema version 2).
void rewrite(const io::ModelFileReader& reader, const std::filesystem::path& out) {
  io::Provenance provenance = reader.provenance();
  const std::string& kind = provenance.model_kind;
  provenance.length_unit = kind == io::kGaFuzzyImmKind ? "km" : "m";  // seed 000 works in km
  io::ModelFileWriter writer(out, provenance);
  if (kind == io::kPlainImmKind) {
    io::write_plain_imm(writer, io::read_plain_imm(reader));
  } else if (kind == io::kGaFuzzyImmKind) {
    io::write_ga_fuzzy_imm(writer, io::read_ga_fuzzy_imm(reader));
  } else if (kind == io::kWimmKind) {
    io::write_wimm(writer, io::read_wimm(reader));
  } else if (kind == io::kFcmImmKind) {
    io::write_fcm_imm(writer, io::read_fcm_imm(reader));
  } else if (kind == io::kMlpInputEstimatorKind) {
    io::write_mlp_input_estimator(writer, io::read_mlp_input_estimator(reader));
  } else if (kind == io::kTskSensorKind) {
    io::write_tsk_sensor(writer, io::read_tsk_sensor(reader));
    if (const auto fimm = io::read_fimm_settings(reader)) io::write_fimm_settings(writer, *fimm);
  } else {
    FAIL() << "no rewrite for kind " << kind;
  }
  writer.commit();
}

TEST(SchemaVersion1, EveryKindStillReadsAndTracksLikeItsVersion2Rewrite) {
  const auto files = version1_files();
  ASSERT_EQ(files.size(), 6U) << "one version-1 file of every kind";
  const testing::TempDir dir;
  for (const auto& path : files) {
    SCOPED_TRACE(path.filename().string());
    const io::ModelFileReader old_reader(path);
    ASSERT_EQ(old_reader.schema_version(), 1);
    EXPECT_EQ(old_reader.provenance().length_unit, "") << "a version-1 file does not say";
    const auto upgraded = dir.path() / path.filename();
    rewrite(old_reader, upgraded);
    const io::ModelFileReader new_reader(upgraded);
    ASSERT_EQ(new_reader.schema_version(), kBaseModelSchemaVersion);
    EXPECT_EQ(new_reader.provenance().config_toml, old_reader.provenance().config_toml);

    Tracker old_tracker = load_tracker(path);
    Tracker new_tracker = load_tracker(upgraded);
    const TrackOptions options = load_filter(path).options;
    int compared = 0;
    for (const auto& [k, z] : testing::seeded_plots(options, 5, 60)) {
      const TrackStepResult a = old_tracker.process(k, z), b = new_tracker.process(k, z);
      ASSERT_EQ(a.event, b.event) << "scan " << k;
      if (!old_tracker.initialized()) continue;
      Eigen::VectorXd m1(old_tracker.state_dimension()), v1(old_tracker.state_dimension());
      Eigen::VectorXd m2(new_tracker.state_dimension()), v2(new_tracker.state_dimension());
      old_tracker.state(m1, v1);
      new_tracker.state(m2, v2);
      ASSERT_TRUE((m1.array() == m2.array()).all()) << "scan " << k;
      ASSERT_TRUE((v1.array() == v2.array()).all()) << "scan " << k;
      ++compared;
    }
    EXPECT_GT(compared, 40);
  }
}

// Every dataset of every kind's version-2 file has units, every matrix its columns, every group
// with real attributes a units entry for each of them.
TEST(SchemaVersion2, EveryKindsFileDescribesItself) {
  const testing::TempDir dir;
  for (const auto& path : version1_files()) {
    SCOPED_TRACE(path.filename().string());
    const auto upgraded = dir.path() / path.filename();
    rewrite(io::ModelFileReader(path), upgraded);
    const io::ContainerReader file(upgraded, io::kModelFormat);
    const auto text = [&](const std::string& object, const std::string& name) {
      const auto value = file.attribute(object, name);
      return value && std::holds_alternative<std::string>(*value) ? std::get<std::string>(*value)
                                                                  : std::string();
    };
    EXPECT_EQ(text("/", "length_unit"),
              path.stem() == "ga_fuzzy_imm" ? std::string("km") : std::string("m"));
    int datasets = 0, matrices = 0, groups_with_reals = 0;
    for (const auto& object : file.objects()) {
      if (file.kind(object) == io::ObjectKind::kDataset) {
        ++datasets;
        EXPECT_FALSE(text(object, "units").empty()) << object;
        if (file.shape(object).size() == 2) {
          ++matrices;
          const std::string columns = text(object, "columns");
          EXPECT_EQ(static_cast<std::size_t>(std::count(columns.begin(), columns.end(), ',') + 1),
                    file.shape(object)[1])
              << object << ": " << columns;
        }
        continue;
      }
      if (object == "/") continue;
      const std::string units = "," + text(object, "units");
      bool has_reals = false;
      for (const auto& name : file.attribute_names(object)) {
        const auto value = file.attribute(object, name);
        if (!std::holds_alternative<double>(*value)) continue;
        has_reals = true;
        EXPECT_NE(units.find("," + name + "="), std::string::npos) << object << "@" << name;
      }
      groups_with_reals += has_reals ? 1 : 0;
    }
    EXPECT_GE(datasets, 2);
    EXPECT_GE(matrices, 1);
    EXPECT_GE(groups_with_reals, 1);
  }
}

// A hand-written expectation of one field's units, independent of the writer's helpers.
TEST(SchemaVersion2, UnitsFollowTheLengthUnitAndTheNoiseForm) {
  const testing::TempDir dir;
  const auto plain = dir.path() / "plain.h5";
  rewrite(io::ModelFileReader(testing::source_root() / "tests/data/schema_v1/cv3_imm.h5"), plain);
  const auto ga = dir.path() / "ga.h5";
  rewrite(io::ModelFileReader(testing::source_root() / "tests/data/schema_v1/ga_fuzzy_imm.h5"), ga);
  const io::ContainerReader p(plain, io::kModelFormat), g(ga, io::kModelFormat);
  const auto text = [](const io::ContainerReader& file, const char* object, const char* name) {
    return std::get<std::string>(*file.attribute(object, name));
  };
  EXPECT_EQ(text(p, "/imm", "units"), "sample_period=s");
  EXPECT_EQ(text(p, "/imm/modes/mode0", "units"),
            "process_noise=m^2/s^4,tau=s,sigma_a=m/s^2");  // piecewise-constant CV noise
  EXPECT_EQ(text(p, "/measurement/covariance", "units"), "m,m");
  EXPECT_EQ(text(p, "/measurement/covariance", "quantity"), "covariance");
  EXPECT_EQ(text(p, "/imm/transition", "columns"), "quiet,moderate,agile");
  EXPECT_EQ(text(g, "/ga_fuzzy_imm/level0/rules", "units"), "km,km,km,km,km^2/s^4");
  EXPECT_EQ(text(g, "/ga_fuzzy_imm/level0", "units"), "maneuver_level=km/s^2");
}

// The field load_filter (every field read, the filter built) refuses, or "read".
std::string refusal(const std::filesystem::path& path) {
  try {
    (void)load_filter(path);
    return "read";
  } catch (const io::FileError& error) {
    return error.field();
  }
}

TEST(SchemaVersion2, AMissingOrMalformedDescriptionIsRefusedNamingTheField) {
  const testing::TempDir dir;
  const auto good = dir.path() / "good.h5";
  rewrite(io::ModelFileReader(testing::source_root() / "tests/data/schema_v1/cv3_imm.h5"), good);
  ASSERT_EQ(refusal(good), "read");
  struct Case {
    std::string name;
    std::function<void(hid_t)> edit;
    std::string field;
  };
  const auto remove = [](const char* object, const char* name) {
    return [=](hid_t file) { ASSERT_GE(H5Adelete_by_name(file, object, name, H5P_DEFAULT), 0); };
  };
  const auto replace = [](const char* object, const char* name, const char* text) {
    return [=](hid_t file) { testing::set_text_attribute(file, object, name, text); };
  };
  const std::vector<Case> cases = {
      {"no columns", remove("/imm/transition", "columns"), "/imm/transition@columns"},
      {"no units", remove("/imm/transition", "units"), "/imm/transition@units"},
      {"two columns of three", replace("/imm/transition", "columns", "a,b"),
       "/imm/transition@columns"},
      {"units per entry of a 3-vector", replace("/imm/initial_probabilities", "units", "1,1"),
       "/imm/initial_probabilities@units"},
      {"a real without units", replace("/imm/modes/mode1", "units", "tau=s,sigma_a=m/s^2"),
       "/imm/modes/mode1@units"},
      {"not name=unit", replace("/imm", "units", "sample_period"), "/imm@units"},
      {"unknown length unit", replace("/", "length_unit", "ft"), "/@length_unit"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const auto bad = dir.path() / "bad.h5";
    std::filesystem::copy_file(good, bad, std::filesystem::copy_options::overwrite_existing);
    testing::edit_and_reseal(bad, c.edit);
    EXPECT_EQ(refusal(bad), c.field);
  }
}

TEST(SchemaVersion2, TheWriterRefusesADescriptionThatDoesNotFit) {
  const testing::TempDir dir;
  io::Provenance provenance;
  provenance.model_kind = "plain_imm";
  io::ModelFileWriter writer(dir.path() / "x.h5", provenance);
  const Eigen::MatrixXd m = Eigen::MatrixXd::Ones(2, 3);
  const auto field_of = [](const auto& write) {
    try {
      write();
      return std::string("written");
    } catch (const io::FileError& error) {
      return error.field();
    }
  };
  EXPECT_EQ(field_of([&] { writer.write_matrix("/a", m, {"x", "y"}, "m"); }), "/a@columns");
  EXPECT_EQ(field_of([&] { writer.write_matrix("/a", m, {"x", "y", "z"}, "m,s"); }), "/a@units");
  EXPECT_EQ(field_of([&] { writer.write_vector("/b", Eigen::Vector3d::Ones(), "m,m"); }),
            "/b@units");
  EXPECT_EQ(field_of([&] { writer.set_attribute("/g", "q", 2.0); }), "/g@q");
  EXPECT_EQ(field_of([&] { writer.set_quantity("/g", "q", 2.0, "m^2/s^4"); }), "written");
  provenance.length_unit = "furlong";
  EXPECT_THROW(io::ModelFileWriter(dir.path() / "y.h5", provenance), io::FileError);
}

}  // namespace
}  // namespace imm
