// SPDX-License-Identifier: Apache-2.0
// The hostile-HDF5 drill (testing/hostile_hdf5.hpp) on the three kinds of data-set file: every
// mutation behind a valid checksum is refused with a FileError naming the file, or read — never a
// hang, a crash or another exception. Structural mutations (cycles, links, shared objects, named
// datatypes) are always refused.

#include <gtest/gtest.h>

#include <functional>
#include <iostream>

#include "imm/datasets/dataset_file.hpp"
#include "imm/datasets/range_sensor_file.hpp"
#include "imm/datasets/track.hpp"
#include "testing/hostile_hdf5.hpp"
#include "testing/temp_dir.hpp"

namespace imm::datasets {
namespace {

struct DatasetKind {
  std::string name;
  std::function<void(const std::filesystem::path&)> write;
  std::function<void(const std::filesystem::path&)> read;
};

void PrintTo(const DatasetKind& kind, std::ostream* out) { *out << kind.name; }

class HostileDatasetFile : public ::testing::TestWithParam<DatasetKind> {};

TEST_P(HostileDatasetFile, EveryMutationIsRefusedOrReads) {
  const DatasetKind& kind = GetParam();
  const testing::TempDir dir;
  const auto original = dir / "original.h5";
  kind.write(original);
  kind.read(original);
  const auto bytes = testing::read_bytes(original);
  std::size_t drilled = 0, refused = 0;
  for (const testing::Mutation& mutation : testing::mutations_of(testing::layout_of(original))) {
    SCOPED_TRACE(mutation.name);
    const auto path = dir / "hostile.h5";
    testing::write_bytes(path, bytes);
    testing::edit_and_reseal(path, mutation.apply, kDatasetFormat);
    ++drilled;
    try {
      kind.read(path);
      EXPECT_FALSE(mutation.structural) << "accepted";
    } catch (const io::FileError& error) {
      ++refused;
      EXPECT_EQ(error.file(), path.string());
    } catch (const std::exception& error) {
      ADD_FAILURE() << "not a FileError: " << error.what();
    }
  }
  std::cout << kind.name << ": drilled " << drilled << " hostile files, " << refused
            << " refused\n";
}

Regime small_regime(SensorKind kind) {
  Regime r;
  r.name = "small";
  r.scans = 20;
  r.sensor.kind = kind;
  r.sensor.calibration.samples = 20;
  r.start.fixed = true;
  r.start.position = Eigen::Vector2d(10.0, 30.0);
  r.start.velocity = Eigen::Vector2d(1.0, 0.0);
  r.cases.push_back({"only", std::nullopt, std::nullopt, {}});
  r.text = "name = \"small\"\n";
  return r;
}

INSTANTIATE_TEST_SUITE_P(
    Kinds, HostileDatasetFile,
    ::testing::Values(DatasetKind{"tracks",
                                  [](const std::filesystem::path& p) {
                                    const Regime r = small_regime(SensorKind::kCartesian);
                                    write_track_set(p, r, draw_split(r, Split::kTest, 1, 2), "v1");
                                  },
                                  [](const std::filesystem::path& p) { (void)read_track_set(p); }},
                      DatasetKind{"range_sensor",
                                  [](const std::filesystem::path& p) {
                                    const Regime r = small_regime(SensorKind::kRangeSensor);
                                    write_range_sensor_dataset(p, r, draw_calibration(r.sensor, 1),
                                                               1, "v1");
                                  },
                                  [](const std::filesystem::path& p) {
                                    (void)read_range_sensor_dataset(p);
                                  }}),
    [](const ::testing::TestParamInfo<DatasetKind>& param) { return param.param.name; });

}  // namespace
}  // namespace imm::datasets
