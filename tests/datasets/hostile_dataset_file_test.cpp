// The hostile-HDF5 drill (testing/hostile_hdf5.hpp) on the three kinds of data-set file: every
// mutation behind a valid checksum is refused with a FileError naming the file, or read — never a
// hang, a crash or another exception. Structural mutations (cycles, links, shared objects, named
// datatypes) are always refused.

#include <gtest/gtest.h>

#include <functional>
#include <iostream>

#include "imm/datasets/dataset_file.hpp"
#include "imm/datasets/maneuver_scenario.hpp"
#include "imm/datasets/range_sensor_file.hpp"
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

ManeuverScenario small_scenario() {
  ManeuverScenario s = seed000_scenario();
  s.runs = 2;
  s.steps = 20;
  s.maneuvers.clear();
  return s;
}

INSTANTIATE_TEST_SUITE_P(
    Kinds, HostileDatasetFile,
    ::testing::Values(
        DatasetKind{"scenario",
                    [](const std::filesystem::path& p) {
                      const ManeuverScenario s = small_scenario();
                      write_scenario_dataset(p, s, simulate(s), "seed = 1\n", "v1");
                    },
                    [](const std::filesystem::path& p) { (void)read_scenario_dataset(p); }},
        DatasetKind{"range_sensor",
                    [](const std::filesystem::path& p) {
                      RangeSensorDataConfig config;
                      config.samples = 20;
                      write_range_sensor_dataset(p, config, simulate_range_sensor(config),
                                                 "seed = 1\n", "v1");
                    },
                    [](const std::filesystem::path& p) { (void)read_range_sensor_dataset(p); }},
        DatasetKind{"cut_in",
                    [](const std::filesystem::path& p) {
                      CutInScenario scenario;
                      scenario.runs = 2;
                      scenario.steps = 20;
                      write_cut_in_dataset(p, scenario, simulate_cut_in(scenario), "", "v1");
                    },
                    [](const std::filesystem::path& p) { (void)read_cut_in_dataset(p); }}),
    [](const ::testing::TestParamInfo<DatasetKind>& info) { return info.param.name; });

}  // namespace
}  // namespace imm::datasets
