// SPDX-License-Identifier: Apache-2.0
// imm-data: writes seeded, reproducible data sets drawn from a regime (configs/regimes/…).
//
//   imm-data tracks --regime configs/regimes/paper/ga_imm_table3.toml --out data/seed000.h5
//                   [--split test|training|validation] [--seed N] [--count N]
//                   [--csv data/ga_imm_table3_run0.csv] [--csv-track I]
//   imm-data sensor --regime configs/regimes/paper/fimm_table1.toml --out data/range_sensor.h5
//                   [--seed N]
//   imm-data import --out data/recorded.h5 [--name N] [--sensor cartesian|polar|range_sensor]
//   [--units m|km]
//                   [--sample-period T] [--tolerance F] [--scans N] FILE.csv…
//   imm-data export (--regime R [--split S] [--seed N] [--count N] | --data set.h5)
//                   --out-dir DIR [--no-truth]
//   imm-data scenes --regime R --out-dir DIR [--count N] [--split S] [--seed N] [--targets N]
//                   [--pd P] [--clutter L]
//
// `scenes` writes several targets at once among clutter (imm/datasets/scene.hpp; the regime's
// [scene] unless --targets, --pd or --clutter say otherwise): per scene scene_000.csv, one row per
// plot (k, t, the plot, origin: the target's index or −1 for clutter), and scene_000_truth.csv
// (k, t, target, x, vx, y, vy).
//
// `import` reads recorded tracks (imm/datasets/recorded.hpp: one CSV per track or a `track`
// column, checked line by line) into a track set that a recorded regime names; `export` writes a
// set's tracks as such CSV files, one per track (what a user's recordings look like).
//
// `tracks` writes a split of the regime (the test split of --seed, default 1; the training and
// validation splits of the regime's own seed), `sensor` the calibration samples of its range
// sensor (what `imm-train tsk` fits; the trainer draws the same samples for the same seed).
//
// Exit codes: 0 success, 1 usage, 2 invalid regime or unwritable output.

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>

#include "imm/build_info.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/datasets/dataset_file.hpp"
#include "imm/datasets/random.hpp"
#include "imm/datasets/range_sensor_file.hpp"
#include "imm/datasets/recorded.hpp"
#include "imm/datasets/regime_file.hpp"
#include "imm/datasets/scene.hpp"
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
  if (!out.flush()) throw std::runtime_error(path + ": write failed");
}

// "with truth", "without truth" or "with truth for N of M recordings".
std::string truth_text(const imm::datasets::TrackSet& set) {
  if (set.recording_truth.empty()) return set.has_truth ? "with truth" : "without truth";
  const auto with = std::count(set.recording_truth.begin(), set.recording_truth.end(), true);
  return "with truth for " + std::to_string(with) + " of " +
         std::to_string(set.recording_truth.size()) + " recordings";
}

int import_recordings(const std::vector<std::string>& inputs, const std::string& out_path,
                      const std::string& name, const std::string& sensor_name,
                      const std::string& units_name, imm::datasets::ImportOptions options) {
  options.name = name;
  options.kind = imm::datasets::sensor_kind_named(sensor_name, "--sensor");
  options.units = imm::datasets::units_named(units_name, "--units");
  imm::datasets::ImportReport report;
  const imm::datasets::TrackSet set = imm::datasets::import_recording_files(
      std::vector<std::filesystem::path>(inputs.begin(), inputs.end()), options, &report);
  const std::filesystem::path folder = std::filesystem::path(out_path).parent_path();
  if (!folder.empty()) std::filesystem::create_directories(folder);
  const std::string digest = imm::datasets::write_track_set(
      out_path, imm::datasets::recording_header(options, set), set, imm::kBuildVersion);
  std::cout << "imm-data: " << report.recordings << " recordings, " << report.windows
            << " tracks x " << report.scans << " scans at T = " << report.sample_period << " s ("
            << report.gap_scans << " gap scans, " << report.dropped_scans
            << " scans after the last whole window dropped"
            << (report.repeated_lines > 0
                    ? ", " + std::to_string(report.repeated_lines) + " repeated lines dropped"
                    : std::string())
            << "), " << truth_text(set) << " -> " << out_path << " (sha256 " << digest.substr(0, 16)
            << ")\n";
  return 0;
}

int export_recordings(const std::string& regime_path, const std::string& data_path,
                      const std::string& split_name, std::uint64_t seed, int count,
                      const std::string& out_dir, bool no_truth) {
  imm::datasets::TrackSet set;
  imm::datasets::SensorKind kind = imm::datasets::SensorKind::kCartesian;
  if (!data_path.empty()) {
    const imm::datasets::TrackSetFile file = imm::datasets::read_track_set(data_path);
    set = file.set;
    kind = file.sensor == "polar"          ? imm::datasets::SensorKind::kPolar
           : file.sensor == "range_sensor" ? imm::datasets::SensorKind::kRangeSensor
                                           : imm::datasets::SensorKind::kCartesian;
    if (count > 0 && static_cast<std::size_t>(count) < set.tracks.size()) {
      set.tracks.resize(static_cast<std::size_t>(count));
    }
  } else if (!regime_path.empty()) {
    const imm::datasets::Regime regime = imm::datasets::load_regime(regime_path).regime;
    kind = regime.sensor.kind;
    set = imm::datasets::draw_split(regime, imm::datasets::split_named(split_name, "--split"), seed,
                                    count);
  } else {
    throw std::runtime_error("export: --regime or --data names the tracks");
  }
  std::filesystem::create_directories(out_dir);
  for (std::size_t i = 0; i < set.tracks.size(); ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "track_%03zu.csv", i);
    imm::datasets::write_recording_csv(std::filesystem::path(out_dir) / name, set, kind, i,
                                       set.track_has_truth(i) && !no_truth);
  }
  std::cout << "imm-data: " << set.tracks.size() << " tracks x " << set.scans << " scans -> "
            << out_dir << "/track_*.csv (" << (no_truth ? "without truth" : truth_text(set))
            << ")\n";
  return 0;
}

// The scenes of a regime (read from `regime_path`) as CSV files (see the file comment); numbers
// that read back exactly.
int write_scenes(const imm::datasets::Regime& regime, const std::string& regime_path,
                 const std::string& split_name, std::uint64_t seed, int count,
                 const imm::datasets::SceneSpec& spec, const std::string& out_dir) {
  if (regime.recorded) throw std::runtime_error(regime_path + ": scenes need a drawn regime");
  spec.validate();
  const imm::datasets::Split split = imm::datasets::split_named(split_name, "--split");
  if (count < 0) count = 1;
  std::filesystem::create_directories(out_dir);
  const char* plot_columns =
      regime.sensor.kind == imm::datasets::SensorKind::kPolar
          ? "range,azimuth"
          : (regime.sensor.kind == imm::datasets::SensorKind::kCartesian ? "zx,zy" : "z1,z2");
  long plots = 0, clutter = 0;
  for (int i = 0; i < count; ++i) {
    const imm::datasets::Scene scene = imm::datasets::draw_scene(regime, spec, split, i, seed);
    char name[48];
    std::snprintf(name, sizeof name, "scene_%03d.csv", i);
    std::ofstream out(std::filesystem::path(out_dir) / name);
    std::snprintf(name, sizeof name, "scene_%03d_truth.csv", i);
    std::ofstream truth(std::filesystem::path(out_dir) / name);
    if (!out || !truth) throw std::runtime_error(out_dir + ": cannot write the scene files");
    out << "k,t," << plot_columns << ",origin\n";
    truth << "k,t,target,x,vx,y,vy\n";
    char line[256];
    for (std::size_t k = 0; k < scene.plots.size(); ++k) {
      const double t = static_cast<double>(k) * regime.sample_period;
      for (std::size_t p = 0; p < scene.plots[k].size(); ++p) {
        const Eigen::Vector2d& z = scene.plots[k][p];
        std::snprintf(line, sizeof line, "%zu,%.17g,%.17g,%.17g,%d\n", k, t, z(0), z(1),
                      scene.origins[k][p]);
        out << line;
        ++plots;
        clutter += scene.origins[k][p] < 0 ? 1 : 0;
      }
      for (std::size_t j = 0; j < scene.targets.size(); ++j) {
        const auto x = scene.targets[j].truth.row(static_cast<Eigen::Index>(k));
        std::snprintf(line, sizeof line, "%zu,%.17g,%zu,%.17g,%.17g,%.17g,%.17g\n", k, t, j, x(0),
                      x(1), x(3), x(4));
        truth << line;
      }
    }
    if (!out.flush() || !truth.flush()) throw std::runtime_error(out_dir + ": write failed");
  }
  std::cout << "imm-data: " << regime.name << ", " << count << " scenes of " << spec.targets
            << " targets, Pd " << spec.detection_probability << ", " << spec.clutter_per_scan
            << " false plots per scan (" << plots << " plots, " << clutter << " false) -> "
            << out_dir << "/scene_*.csv\n";
  return 0;
}

int run(int argc, char** argv) {
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
  tracks
      ->add_option("--seed", seed,
                   "test seed (the training and validation splits use the "
                   "regime's [splits] seed)")
      ->check(imm::support::seed());
  // A count is held to what a split may hold (datasets::kMaxSplitTracks), on every command.
  const CLI::Validator count_range = imm::support::within(1, imm::datasets::kMaxSplitTracks, "");
  tracks->add_option("--count", count, "tracks (default: the regime's split size)")
      ->check(count_range);
  tracks->add_option("--csv", csv_path, "also write one track's plots as CSV for imm-track");
  tracks->add_option("--csv-track", csv_track, "which track --csv writes")
      ->check(imm::support::at_least(0));

  auto* sensor = app.add_subcommand("sensor", "the calibration samples of a range sensor");
  sensor->add_option("--regime", regime_path, "regime TOML with a range sensor")->required();
  sensor->add_option("--out", out_path, "data-set file to write (HDF5)")->required();
  sensor->add_option("--seed", seed, "seed of the draw")->check(imm::support::seed());
  std::vector<std::string> inputs;
  std::string name = "recorded", sensor_name = "cartesian", units_name = "m", data_path, out_dir;
  imm::datasets::ImportOptions import_options;
  bool no_truth = false;
  auto* import = app.add_subcommand("import", "recorded tracks (CSV) into a track set");
  import->add_option("files", inputs, "recording CSV files, or folders of them")->required();
  import->add_option("--out", out_path, "track-set file to write (HDF5)")->required();
  import->add_option("--name", name, "the set's name");
  import
      ->add_option("--sensor", sensor_name,
                   "cartesian (zx, zy) | polar (range, azimuth) | range_sensor (z1, z2)")
      ->check(CLI::IsMember({"cartesian", "polar", "range_sensor"}));
  import->add_option("--units", units_name, "m | km")->check(CLI::IsMember({"m", "km"}));
  import
      ->add_option("--sample-period", import_options.sample_period,
                   "s (default: the first track's median step)")
      ->check(imm::support::within(imm::limits::kSamplePeriod.min, imm::limits::kSamplePeriod.max,
                                   "s"));
  import
      ->add_option("--tolerance", import_options.tolerance,
                   "of a sample period, for each time's place on the grid")
      ->check(imm::support::within(1e-9, 0.49, ""));
  import->add_option("--scans", import_options.scans, "per window (default: the shortest track)")
      ->check(imm::support::at_least(3));
  auto* exporter = app.add_subcommand("export", "a track set as recording CSV files");
  auto* from_regime =
      exporter->add_option("--regime", regime_path, "draw the tracks from a regime");
  exporter->add_option("--data", data_path, "or export a track-set file")->excludes(from_regime);
  exporter->add_option("--split", split_name, "test | training | validation")
      ->check(CLI::IsMember({"test", "training", "validation"}));
  exporter->add_option("--seed", seed, "test seed")->check(imm::support::seed());
  exporter->add_option("--count", count, "tracks")->check(count_range);
  exporter->add_option("--out-dir", out_dir, "folder for track_000.csv, …")->required();
  exporter->add_flag("--no-truth", no_truth, "plots only (drop the truth columns)");
  auto* scenes = app.add_subcommand("scenes", "several targets at once among clutter (CSV)");
  std::optional<int> scene_targets;
  std::optional<double> scene_pd, scene_clutter;
  scenes->add_option("--regime", regime_path, "regime TOML (its [scene] by default)")->required();
  scenes->add_option("--out-dir", out_dir, "folder for scene_000.csv, …")->required();
  scenes->add_option("--count", count, "scenes (default 1)")->check(count_range);
  scenes->add_option("--split", split_name, "test | training | validation");
  scenes->add_option("--seed", seed, "test seed")->check(imm::support::seed());
  scenes->add_option("--targets", scene_targets, "targets per scene");
  scenes->add_option("--pd", scene_pd, "detection probability");
  scenes->add_option("--clutter", scene_clutter, "mean false plots per scan");
  if (const auto exit = imm::support::parse(app, argc, argv)) return *exit;

  try {
    if (*scenes) {
      const imm::datasets::Regime regime = imm::datasets::load_regime(regime_path).regime;
      imm::datasets::SceneSpec spec = regime.scene;
      spec.targets = scene_targets.value_or(spec.targets);
      spec.detection_probability = scene_pd.value_or(spec.detection_probability);
      spec.clutter_per_scan = scene_clutter.value_or(spec.clutter_per_scan);
      return write_scenes(regime, regime_path, split_name, seed, count, spec, out_dir);
    }
    if (*import)
      return import_recordings(inputs, out_path, name, sensor_name, units_name, import_options);
    if (*exporter) {
      return export_recordings(regime_path, data_path, split_name, seed, count, out_dir, no_truth);
    }
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
    const imm::datasets::Split split = imm::datasets::split_named(split_name, "--split");
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

}  // namespace

int main(int argc, char** argv) {
  return imm::support::with_output_written("imm-data", run(argc, argv));
}
