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

#include "imm/io/container_file.hpp"
#include "imm/io/fcm_imm_file.hpp"
#include "imm/io/ga_fuzzy_imm_file.hpp"
#include "imm/io/mlp_input_estimator_file.hpp"
#include "imm/io/model_file.hpp"
#include "imm/io/plain_imm_file.hpp"
#include "imm/io/tsk_sensor_file.hpp"
#include "imm/io/wimm_file.hpp"
#include "testing/hostile_hdf5.hpp"
#include "testing/shipped_models.hpp"
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
TEST(HostileModelFile, EveryMutationOfEveryShippedModelIsRefusedOrLoads) {
  const auto models = shipped_models();
  ASSERT_FALSE(models.empty());
  const testing::TempDir dir;
  std::size_t drilled = 0, refused = 0;
  for (const auto& model : models) {
    const Layout layout = layout_of(model);
    const auto bytes = testing::read_bytes(model);
    for (const Mutation& mutation : mutations_of(layout)) {
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

}  // namespace
}  // namespace imm::io
