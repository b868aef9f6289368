// SPDX-License-Identifier: Apache-2.0
// Hostile HDF5 content behind valid checksums, drilled on every shipped model file: link cycles
// (hard and soft), external links, shared objects, wrong object types at every path, huge declared
// dataset sizes, wrong attribute types and absurd values. Each mutated file is resealed (the
// container header is public) and read by its kind's runtime reader, which must refuse it with a
// FileError or load it — never hang, crash or throw anything else.

#include <gtest/gtest.h>
#include <hdf5.h>

#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <set>

#include "imm/io/container_file.hpp"
#include "imm/io/fcm_imm_file.hpp"
#include "imm/io/ga_fuzzy_imm_file.hpp"
#include "imm/io/mlp_input_estimator_file.hpp"
#include "imm/io/model_file.hpp"
#include "imm/io/plain_imm_file.hpp"
#include "imm/io/tsk_sensor_file.hpp"
#include "imm/io/wimm_file.hpp"
#include "imm/tracking/envelope.hpp"
#include "testing/hostile_hdf5.hpp"
#include "testing/shipped_models.hpp"
#include "testing/study.hpp"
#include "testing/temp_dir.hpp"

namespace imm::io {
namespace {

/// Reads a model file with its kind's runtime reader (the validation a tracking application gets).
void read_model(const std::filesystem::path& path) {
  const ModelFileReader model(path);
  const std::string kind = model.provenance().model_kind;
  if (kind == kPlainImmKind) {
    (void)read_plain_imm(path);
  } else if (kind == kGaFuzzyImmKind) {
    (void)read_ga_fuzzy_imm(path);
  } else if (kind == kMlpInputEstimatorKind) {
    (void)read_mlp_input_estimator(path);
  } else if (kind == kWimmKind) {
    (void)read_wimm(path);
  } else if (kind == kFcmImmKind) {
    (void)read_fcm_imm(path);
  } else if (kind == kTskSensorKind) {
    (void)read_tsk_sensor(path);
  } else {
    throw FileError(path.string(), "/@model_kind", "unknown kind '" + kind + "'");
  }
}

using testing::shipped_models;

using testing::Layout;
using testing::layout_of;
using testing::Mutation;
using testing::mutations_of;

void apply_and_reseal(const std::filesystem::path& path, const Mutation& mutation) {
  testing::edit_and_reseal(path, mutation.apply);
}

class SilenceHdf5 : public ::testing::Environment {
 public:
  void SetUp() override { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }
};
const auto* const kSilence = ::testing::AddGlobalTestEnvironment(new SilenceHdf5);

// The drill: every mutation of every shipped model is refused with a FileError naming the file, or
// loads; and the structural ones (cycles, links, shared objects, named types) are always refused.
// The default suite drills one model of each layout (its kind and the names of its objects and
// attributes, indices dropped: the shipped models of a kind differ in their values and counts, not
// in their structure); `make test-long` every shipped model.
TEST(HostileModelFile, EveryMutationOfEveryShippedModelIsRefusedOrLoads) {
  const auto models = shipped_models();
  ASSERT_FALSE(models.empty());
  const testing::TempDir dir;
  std::size_t drilled = 0, refused = 0;
  std::set<std::string> layouts;
  for (const auto& model : models) {
    const Layout layout = layout_of(model);
    const std::vector<Mutation> mutations = mutations_of(layout);
    // Its kind and the names of its objects and attributes with their indices dropped (mode0 and
    // mode7 alike): models that differ only in how many modes or levels they have share one.
    std::set<std::string> names;
    const auto without_digits = [](std::string text) {
      std::erase_if(text, [](char c) { return c >= '0' && c <= '9'; });
      return text;
    };
    for (const auto& [object, name] : layout.attributes) {
      // The root's provenance (its training metrics differ by trainer) is read by one reader.
      if (object != "/") names.insert(without_digits(object) + "@" + without_digits(name));
    }
    for (const auto& object : layout.datasets) names.insert(without_digits(object));
    std::string signature = ModelFileReader(model).provenance().model_kind;
    for (const std::string& name : names) signature += "|" + name;
    if (!layouts.insert(signature).second && !testing::running_as_study()) continue;
    const auto bytes = testing::read_bytes(model);
    for (const Mutation& mutation : mutations) {
      SCOPED_TRACE(model.string() + ": " + mutation.name);
      const auto path = dir / "hostile.h5";
      testing::write_bytes(path, bytes);
      apply_and_reseal(path, mutation);
      ++drilled;
      try {
        read_model(path);
        EXPECT_FALSE(mutation.structural) << "accepted";
      } catch (const FileError& error) {
        ++refused;
        EXPECT_EQ(error.file(), path.string());
        EXPECT_EQ(std::string(error.what()).find('\n'), std::string::npos) << error.what();
      } catch (const std::exception& error) {
        ADD_FAILURE() << "not a FileError: " << error.what();
      }
      // Nothing the reader opened stays open, on the error path as on success (a tracker that
      // refuses a bad model and carries on must not leak HDF5 handles).
      EXPECT_EQ(H5Fget_obj_count(H5F_OBJ_ALL, H5F_OBJ_ALL), 0) << "HDF5 objects left open";
    }
  }
  std::cout << "drilled " << drilled << " hostile files, " << refused << " refused\n";
}

// The walker behind imm-inspect: a hard link from a group to its ancestor is refused when the file
// opens, naming the link, so nothing can walk in a circle.
TEST(HostileModelFile, HardLinkCycleIsRefusedNamingTheLink) {
  const testing::TempDir dir;
  const auto path = dir / "cycle.h5";
  testing::write_bytes(path, testing::read_bytes("models/cv3_imm.h5"));
  apply_and_reseal(path, {"cycle", [](hid_t f) {
                            H5Lcreate_hard(f, "/imm", f, "/imm/modes/up", H5P_DEFAULT, H5P_DEFAULT);
                          }});
  try {
    const ContainerReader reader(path, kModelFormat);
    FAIL() << "accepted";
  } catch (const FileError& error) {
    EXPECT_EQ(error.field(), "/imm/modes/up");
    EXPECT_NE(std::string(error.what()).find("links to '/imm' again"), std::string::npos)
        << error.what();
  }
}

// The refusal of a mutated copy of `model`, or "" when it loads and its tracker (built as
// load_tracker builds it, envelope included) runs.
std::string refusal_of(const std::filesystem::path& model, const testing::TempDir& dir,
                       const std::function<void(hid_t)>& edit) {
  const auto path = dir / "mutant.h5";
  testing::write_bytes(path, testing::read_bytes(model));
  testing::edit_and_reseal(path, edit);
  try {
    const ModelFileReader reader(path);
    read_model(path);
    (void)EnvelopeMonitor(reader.envelope());
    return "";
  } catch (const FileError& error) {
    return error.what();
  }
}

// Every real is checked against its meaning: an envelope whose χ² quantiles cannot be computed
// (significance 5e-324 halves to 0; dof 1e-310 took 10 s) and a count written as a real (−1.0 or
// 2.5 generations) are refused naming the field, not loaded and then thrown on by the tracker.
TEST(HostileModelFile, EveryNumberIsCheckedAgainstItsMeaning) {
  const testing::TempDir dir;
  const std::filesystem::path tracker = "models/baseline_imm_agile_air.h5";
  for (const auto& [name, value] :
       {std::pair{"significance", 5e-324}, std::pair{"significance", 1e-320},
        std::pair{"dof", 1e-310}, std::pair{"dof", 5e-324}, std::pair{"dof", 1e7}}) {
    SCOPED_TRACE(std::string(name) + " = " + std::to_string(value));
    const std::string refused = refusal_of(tracker, dir, [&, name = name, value = value](hid_t f) {
      testing::set_attribute(f, "/envelope", name, H5T_NATIVE_DOUBLE, &value);
    });
    EXPECT_NE(refused.find("/envelope@" + std::string(name)), std::string::npos) << refused;
  }
  const std::filesystem::path ga = "models/ga_fuzzy_imm_agile_air.h5";
  for (const double value : {-1.0, 2.5, 100.0}) {
    SCOPED_TRACE(value);
    const std::string refused = refusal_of(ga, dir, [value](hid_t f) {
      testing::set_attribute(f, "/ga_fuzzy_imm/level0", "generations", H5T_NATIVE_DOUBLE, &value);
    });
    // Named by its group's units (a real needs one) or by itself (a count must be an integer).
    EXPECT_NE(refused.find("/ga_fuzzy_imm/level0@"), std::string::npos) << refused;
    EXPECT_NE(refused.find("generations"), std::string::npos) << refused;
  }
  const std::int64_t too_many = 1000;
  EXPECT_NE(refusal_of(ga, dir,
                       [&](hid_t f) {
                         testing::set_attribute(f, "/ga_fuzzy_imm/level0", "rules",
                                                H5T_NATIVE_INT64, &too_many);
                       })
                .find("@rules"),
            std::string::npos);
  // The unmutated files load (the checks refuse the mutation, not the model).
  EXPECT_EQ(refusal_of(tracker, dir, [](hid_t) {}), "");
  EXPECT_EQ(refusal_of(ga, dir, [](hid_t) {}), "");
}

// Text is text: control bytes (newline, CR, ESC) in the provenance's one-line texts, and in group
// or attribute names, are refused with a one-line message that shows them escaped; a name longer
// than the documented 256 bytes is refused too.
TEST(HostileModelFile, TextHoldsNoControlBytesAndNamesKeepTheirLimit) {
  const testing::TempDir dir;
  const std::filesystem::path model = "models/cv3_imm.h5";
  for (const char* attribute :
       {"model_kind", "length_unit", "created_utc", "trainer_version", "dataset_digest"}) {
    for (const std::string bad : {"m\nx", "m\rx", "m\x1b[31mx"}) {
      SCOPED_TRACE(std::string(attribute) + " = " + bad);
      const std::string refused = refusal_of(
          model, dir, [&](hid_t f) { testing::set_text_attribute(f, "/", attribute, bad); });
      EXPECT_NE(refused.find(std::string("/@") + attribute), std::string::npos) << refused;
      EXPECT_EQ(refused.find_first_of("\n\r\x1b"), std::string::npos) << refused;
    }
  }
  const double value = 1.0;
  for (const std::string& name :
       {std::string("bad\nname"), std::string("esc\x1b"), std::string(300, 'a')}) {
    SCOPED_TRACE(name.size());
    const std::string refused = refusal_of(model, dir, [&](hid_t f) {
      testing::set_attribute(f, "/imm", name, H5T_NATIVE_DOUBLE, &value);
    });
    EXPECT_NE(refused.find("attribute name"), std::string::npos) << refused;
    EXPECT_EQ(refused.find_first_of("\n\r\x1b"), std::string::npos) << refused;
    const std::string group = refusal_of(model, dir, [&](hid_t f) {
      H5Gclose(H5Gcreate2(f, ("/imm/" + name).c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
    });
    EXPECT_NE(group.find("name"), std::string::npos) << group;
    EXPECT_EQ(group.find_first_of("\n\r\x1b"), std::string::npos) << group;
  }
}

}  // namespace
}  // namespace imm::io
