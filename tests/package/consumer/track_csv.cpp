// SPDX-License-Identifier: Apache-2.0
// The complete consumer example of docs/integrating.md: a tracking application that links only
// imm::runtime, loads any immtrain model file and tracks the plots of a CSV file.
//
//   track_csv MODEL.h5 PLOTS.csv
//
// PLOTS.csv has a header line and rows "scan,z1,z2": Cartesian x, y for most models, range and
// azimuth (rad, clockwise from the y axis) for a model of polar plots (a WIMM), the sensor's
// outputs for a TSK sensor model; a missing scan is a gap. Prints one line per plot: the scan,
// what the tracker did, the position estimate and the most probable mode.
#include <cstdio>
#include <exception>
#include <fstream>
#include <imm/load.hpp>
#include <imm/version.hpp>
#include <sstream>
#include <string>

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: track_csv MODEL.h5 PLOTS.csv\n");
    return 1;
  }
  try {
    // One call for every model kind: the file's kind-specific reader, its filter and the track
    // options it was trained with. Bad files throw imm::io::FileError naming the field.
    imm::Tracker tracker = imm::load_tracker(argv[1]);
    std::printf("# %s: %d modes, state %d, runtime %s (model schema %d)\n", argv[1],
                tracker.mode_count(), tracker.state_dimension(), imm::kVersion,
                imm::kModelSchemaVersion);

    std::ifstream plots(argv[2]);
    if (!plots) throw std::runtime_error(std::string(argv[2]) + ": cannot open");
    std::string line;
    std::getline(plots, line);  // header
    Eigen::VectorXd mean(tracker.state_dimension()), variance(tracker.state_dimension());
    while (std::getline(plots, line)) {
      std::istringstream row(line);
      long long scan = 0;
      double z1 = 0.0, z2 = 0.0;
      char comma1 = 0, comma2 = 0;
      if (!(row >> scan >> comma1 >> z1 >> comma2 >> z2) || comma1 != ',' || comma2 != ',') {
        throw std::runtime_error(std::string(argv[2]) + ": bad row '" + line + "'");
      }
      // Plots with NaN, a scan that does not increase or a plot the filter cannot use are
      // rejected and leave the track as it was; skipped scans are predicted through.
      const imm::TrackStepResult result = tracker.process(scan, Eigen::Vector2d(z1, z2));
      std::printf("%lld %s", scan, std::string(imm::to_string(result.event)).c_str());
      if (tracker.initialized()) {
        tracker.state(mean, variance);  // state layout: [x, vx, y, vy] or [x, vx, ax, y, vy, ay]
        const int y = tracker.state_dimension() == 4 ? 2 : 3;
        int mode = 0;
        tracker.mode_probabilities().maxCoeff(&mode);
        std::printf(" x=%.6g y=%.6g mode=%s", mean(0), mean(y),
                    tracker.filter().mode_name(mode).c_str());
      }
      std::printf("\n");
    }
    return 0;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "track_csv: %s\n", error.what());
    return 2;
  }
}
