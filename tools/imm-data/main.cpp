// imm-data: writes a simulated data set (truth, measurements, parameters) to a data-set file.
//
//   imm-data seed000 --out data/seed000.h5 [--config configs/data/seed000.toml]
//                    [--runs N] [--seed N] [--csv data/seed000_run0.csv] [--csv-run R]
//   imm-data maneuver --config my_scenario.toml --out data/my.h5
//   imm-data range-sensor --out data/range_sensor.h5 [--config configs/tsk_range_sensor.toml]
//   imm-data cut-in --out data/cut_in.h5 [--r-sigma 0.5] [--runs N] [--config …]
//
// Exit codes: 0 success, 1 usage, 2 invalid config or unwritable output.

#include <CLI/CLI.hpp>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>

#include "imm/build_info.hpp"
#include "imm/datasets/dataset_file.hpp"
#include "imm/datasets/range_sensor_file.hpp"
#include "imm/support/scenario_config.hpp"
#include "imm/trainer/tsk/tsk_trainer.hpp"

namespace {

constexpr int kExitBadInput = 2;

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

void write_csv(const std::string& path, const imm::datasets::ManeuverScenario& scenario,
               const Eigen::MatrixXd& measurements) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error(path + ": cannot write");
  out << (scenario.measurement.kind == imm::MeasurementKind::kCartesian ? "k,zx,zy\n"
                                                                        : "k,range,azimuth\n");
  char line[96];
  for (Eigen::Index k = 0; k < measurements.rows(); ++k) {
    std::snprintf(line, sizeof line, "%ld,%.12g,%.12g\n", static_cast<long>(k), measurements(k, 0),
                  measurements(k, 1));
    out << line;
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Generate a seeded, reproducible data set."};
  std::string scenario_name, out_path, config_path, csv_path;
  int runs = -1, csv_run = 0;
  std::int64_t seed = -1;
  app.add_option("scenario", scenario_name,
                 "seed000 | seed003 | seed004-1 | seed004-2 | maneuver | range-sensor | cut-in")
      ->required()
      ->check(CLI::IsMember(
          {"seed000", "seed003", "seed004-1", "seed004-2", "maneuver", "range-sensor", "cut-in"}));
  app.add_option("--out", out_path, "data-set file to write (HDF5)")->required();
  app.add_option("--config", config_path, "scenario TOML (overrides the scenario's defaults)");
  app.add_option("--runs", runs, "Monte Carlo runs (overrides the config)")
      ->check(CLI::PositiveNumber);
  app.add_option("--seed", seed, "random seed (overrides the config)")
      ->check(CLI::NonNegativeNumber);
  double accel_scale = 1.0;
  app.add_option("--accel-scale", accel_scale,
                 "seed003: multiply the accelerations (10: the seed's literal 0.3-0.6 km/s^2)")
      ->check(CLI::PositiveNumber);
  double r_sigma = 0.5;
  app.add_option("--r-sigma", r_sigma, "cut-in: the plots' noise σ per axis, m (R = σ² I)")
      ->check(CLI::PositiveNumber);
  app.add_option("--csv", csv_path, "also write one run's measurements as CSV for imm-track");
  app.add_option("--csv-run", csv_run, "which run --csv writes")->check(CLI::NonNegativeNumber);
  CLI11_PARSE(app, argc, argv);

  try {
    if (scenario_name == "range-sensor" || scenario_name == "cut-in") {
      // Seed 002: the sensor and the scenario come from a TSK config ([data], [scenario]).
      const std::string config_file =
          config_path.empty() ? std::string("configs/tsk_range_sensor.toml") : config_path;
      auto config = imm::trainer::tsk::load_tsk_config(config_file);
      if (seed >= 0) {
        config.data.seed = static_cast<std::uint64_t>(seed);
        config.scenario.seed = static_cast<std::uint64_t>(seed);
      }
      std::string digest;
      if (scenario_name == "range-sensor") {
        const auto data = imm::datasets::simulate_range_sensor(config.data);
        digest = imm::datasets::write_range_sensor_dataset(out_path, config.data, data, config.text,
                                                           imm::kBuildVersion);
        std::cout << "imm-data: range sensor, " << config.data.samples
                  << " samples (L = " << config.data.distortion.softness << " m)";
      } else {
        auto scenario = config.scenario;
        scenario.measurement_covariance = r_sigma * r_sigma * Eigen::Matrix2d::Identity();
        if (runs > 0) scenario.runs = runs;
        const auto data = imm::datasets::simulate_cut_in(scenario);
        digest = imm::datasets::write_cut_in_dataset(out_path, scenario, data, config.text,
                                                     imm::kBuildVersion);
        std::cout << "imm-data: cut-in, " << scenario.runs << " runs x " << scenario.steps
                  << " scans, R = " << r_sigma << "^2 I";
      }
      std::cout << " -> " << out_path << " (sha256 " << digest.substr(0, 16) << ")\n";
      return 0;
    }
    imm::datasets::ManeuverScenario scenario = imm::datasets::ManeuverScenario{};
    if (scenario_name == "seed000") scenario = imm::datasets::seed000_scenario();
    if (scenario_name == "seed003") scenario = imm::datasets::seed003_scenario(accel_scale);
    if (scenario_name == "seed004-1") scenario = imm::datasets::seed004_scenario(1);
    if (scenario_name == "seed004-2") scenario = imm::datasets::seed004_scenario(2);
    std::string config_text;
    if (!config_path.empty()) {
      scenario = imm::support::load_scenario_config(config_path, scenario);
      config_text = read_text(config_path);
    } else if (scenario_name == "maneuver") {
      throw std::runtime_error("the maneuver scenario needs --config");
    }
    if (runs > 0) scenario.runs = runs;
    if (seed >= 0) scenario.seed = static_cast<std::uint64_t>(seed);
    if (csv_run >= scenario.runs) throw std::runtime_error("--csv-run is beyond the last run");

    const imm::datasets::ScenarioData data = imm::datasets::simulate(scenario);
    const std::string digest = imm::datasets::write_scenario_dataset(
        out_path, scenario, data, config_text, imm::kBuildVersion);
    if (!csv_path.empty())
      write_csv(csv_path, scenario, data.measurements[static_cast<std::size_t>(csv_run)]);
    std::cout << "imm-data: " << scenario.name << ", " << scenario.runs << " runs x "
              << scenario.steps << " scans, seed " << scenario.seed << " -> " << out_path
              << " (sha256 " << digest.substr(0, 16) << ")\n";
  } catch (const std::exception& error) {
    std::cerr << "imm-data: " << error.what() << '\n';
    return kExitBadInput;
  } catch (...) {
    std::cerr << "imm-data: unexpected error\n";
    return kExitBadInput;
  }
  return 0;
}
