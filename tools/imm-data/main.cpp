// SPDX-License-Identifier: Apache-2.0
// imm-data: writes seeded, reproducible data sets drawn from a regime (configs/regimes/…).
//
//   imm-data tracks --regime configs/regimes/paper/ga_imm_table3.toml --out data/seed000.h5
//                   [--split test|training|validation] [--seed N] [--count N]
//                   [--csv data/ga_imm_table3_run0.csv] [--csv-track I]
//   imm-data sensor --regime configs/regimes/paper/fimm_table1.toml --out data/range_sensor.h5
//                   [--seed N]
//
// `tracks` writes a split of the regime (the test split of --seed, default 1; the training and
// validation splits of the regime's own seed), `sensor` the calibration samples of its range
// sensor (what `imm-train tsk` fits; the trainer draws the same samples for the same seed).
//
// Exit codes: 0 success, 1 usage, 2 invalid regime or unwritable output.

#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>

#include "imm/build_info.hpp"
#include "imm/datasets/dataset_file.hpp"
#include "imm/datasets/random.hpp"
#include "imm/datasets/range_sensor_file.hpp"
#include "imm/datasets/regime_file.hpp"
#include "imm/io/container_file.hpp"
#include "imm/support/cli.hpp"
#include "imm/support/exit_codes.hpp"

namespace {

void write_csv(const std::string& path, const imm::datasets::Regime& regime,
               const Eigen::MatrixXd& plots) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error(path + ": cannot write");
  switch (regime.sensor.kind) {
    case imm::datasets::SensorKind::kCartesian:
      out << "k,zx,zy\n";
      break;
    case imm::datasets::SensorKind::kPolar:
      out << "k,range,azimuth\n";
      break;
    case imm::datasets::SensorKind::kRangeSensor:
      out << "k,z1,z2\n";
      break;
  }
  char line[96];
  for (Eigen::Index k = 0; k < plots.rows(); ++k) {
    std::snprintf(line, sizeof line, "%ld,%.12g,%.12g\n", static_cast<long>(k), plots(k, 0),
                  plots(k, 1));
    out << line;
  }
  if (!out) throw std::runtime_error(path + ": write failed");
}

}  // namespace

int main(int argc, char** argv) {
  imm::io::skip_hdf5_shutdown_at_exit();  // before any HDF5 call (container_file.hpp)
  CLI::App app{"Draw a seeded, reproducible data set from a regime."};
  imm::support::standard_options(app, "imm-data");
  app.require_subcommand(1);
  std::string regime_path, out_path, csv_path;
  std::string split_name = "test";
  int count = -1, csv_track = 0;
  std::uint64_t seed = 1;

  auto* tracks = app.add_subcommand("tracks", "a split of the regime's tracks");
  tracks->add_option("--regime", regime_path, "regime TOML")->required();
  tracks->add_option("--out", out_path, "data-set file to write (HDF5)")->required();
  tracks->add_option("--split", split_name, "test | training | validation")
      ->check(CLI::IsMember({"test", "training", "validation"}));
  tracks->add_option("--seed", seed,
                     "test seed (the training and validation splits use the "
                     "regime's [splits] seed)");
  tracks->add_option("--count", count, "tracks (default: the regime's split size)")
      ->check(imm::support::at_least(1));
  tracks->add_option("--csv", csv_path, "also write one track's plots as CSV for imm-track");
  tracks->add_option("--csv-track", csv_track, "which track --csv writes")
      ->check(imm::support::at_least(0));

  auto* sensor = app.add_subcommand("sensor", "the calibration samples of a range sensor");
  sensor->add_option("--regime", regime_path, "regime TOML with a range sensor")->required();
  sensor->add_option("--out", out_path, "data-set file to write (HDF5)")->required();
  sensor->add_option("--seed", seed, "seed of the draw");
  if (const auto exit = imm::support::parse(app, argc, argv)) return *exit;

  try {
    const imm::datasets::RegimeFile file = imm::datasets::load_regime(regime_path);
    for (const std::string& written : {out_path, csv_path}) {  // their folders, as needed
      const std::filesystem::path folder = std::filesystem::path(written).parent_path();
      if (!written.empty() && !folder.empty()) std::filesystem::create_directories(folder);
    }
    const imm::datasets::Regime& regime = file.regime;
    if (*sensor) {
      if (regime.sensor.kind != imm::datasets::SensorKind::kRangeSensor) {
        throw std::runtime_error(regime_path + ": sensor.kind: a range sensor is needed");
      }
      const auto data = imm::datasets::draw_calibration(regime.sensor, seed);
      const std::string digest = imm::datasets::write_range_sensor_dataset(
          out_path, regime, data, seed, imm::kBuildVersion);
      std::cout << "imm-data: " << regime.name << ", " << data.positions.rows()
                << " sensor samples, seed " << seed << " -> " << out_path << " (sha256 "
                << digest.substr(0, 16) << ")\n";
      return 0;
    }
    static const std::map<std::string, imm::datasets::Split> splits = {
        {"test", imm::datasets::Split::kTest},
        {"training", imm::datasets::Split::kTraining},
        {"validation", imm::datasets::Split::kValidation}};
    const imm::datasets::Split split = splits.at(split_name);
    const imm::datasets::TrackSet set = imm::datasets::draw_split(regime, split, seed, count);
    if (set.tracks.empty()) throw std::runtime_error(regime_path + ": the split holds no tracks");
    if (csv_track >= static_cast<int>(set.tracks.size())) {
      throw std::runtime_error("--csv-track is beyond the last track");
    }
    const std::string digest =
        imm::datasets::write_track_set(out_path, regime, set, imm::kBuildVersion);
    if (!csv_path.empty()) {
      write_csv(csv_path, regime, set.tracks[static_cast<std::size_t>(csv_track)].plots);
    }
    std::cout << "imm-data: " << regime.name << " " << split_name << " split, " << set.tracks.size()
              << " tracks x " << set.scans << " scans, seed " << set.seed << " -> " << out_path
              << " (sha256 " << digest.substr(0, 16) << ")\n";
  } catch (const std::exception& error) {
    std::cerr << "imm-data: " << error.what() << '\n';
    return imm::support::exit_code::kBadInput;
  } catch (...) {
    std::cerr << "imm-data: unexpected error\n";
    return imm::support::exit_code::kBadInput;
  }
  return 0;
}
