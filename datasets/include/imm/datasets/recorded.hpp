// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Recorded tracks: an engineer's own plots, read from CSV files, checked, and turned into a track
/// set (imm/datasets/dataset_file.hpp) that a recorded regime names (imm/datasets/regime.hpp).
///
/// A recording is one CSV file per track, or one CSV file with a `track` column (rows of a track
/// need not be contiguous; their order within the track must be). The first line that is not
/// blank or a comment is the header; its columns, in any order:
///   t                       time, s (strictly increasing within a track)
///   zx, zy | range, azimuth | z1, z2
///                           the plots (Cartesian; polar with the azimuth in radians from north;
///                           a range sensor's two outputs, seed 002)
///   track                   optional: the track's name
///   x, vx, y, vy            optional truth (the whole file has it or not)
/// Any other column is refused by name. Values are strict numbers; a non-finite one is refused
/// with the file, the line and the column. A time after the first is a whole number of sample
/// periods after the track's first within the tolerance; a larger step is a gap (its scans become
/// plots of NaN, which the filters predict through), a step that is not a whole number of periods
/// is refused. Truth accelerations are the velocity's forward differences, (v(k+1) − v(k))/T (the
/// last scan repeats the one before).
///
/// Tracks of any length are cut into windows of `scans` scans (the tail shorter than a window is
/// dropped and counted); every window remembers its recording, so a regime's splits keep a
/// recording's windows together.

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "imm/datasets/regime.hpp"
#include "imm/datasets/track.hpp"

namespace imm::datasets {

/// One recorded track as read: times, plots and (when present) truth x, vx, y, vy.
struct RecordedTrack {
  std::string name;                ///< the file's stem, or the `track` column's value
  std::string file;                ///< where it was read from (errors name it)
  std::vector<std::size_t> lines;  ///< the CSV line of each row
  Eigen::VectorXd times;
  Eigen::MatrixXd plots;  ///< rows × 2
  Eigen::MatrixXd truth;  ///< rows × 4 (x, vx, y, vy), or rows × 0 without truth
  /// The CSV lines dropped as exact repeats of the track's row before them (a logger that wrote
  /// a line twice); a row at the same time with other values is refused.
  std::vector<std::size_t> repeated_lines;
};

/// What the plots are (checked against the header's columns).
struct RecordingFormat {
  SensorKind kind = SensorKind::kCartesian;
};

/// Reads one CSV file: one track, or several with a `track` column. Throws std::runtime_error
/// "file:line: column …" for anything that cannot be used.
[[nodiscard]] std::vector<RecordedTrack> read_recording(const std::filesystem::path& path,
                                                        const RecordingFormat& format);

struct ImportOptions {
  double sample_period = 0.0;  ///< s; 0: the median step of the first track
  double tolerance = 0.05;     ///< of a sample period, for every time's place on the grid
  int scans = 0;               ///< per window; 0: the shortest track's scans
  Units units = Units::kMetres;
  SensorKind kind = SensorKind::kCartesian;
  std::string name = "recorded";  ///< the set's name (regimes name the file)
};

/// What an import did: windows written, scans dropped as tails, gaps filled.
struct ImportReport {
  int recordings = 0, windows = 0;
  long dropped_scans = 0, gap_scans = 0;
  long repeated_lines = 0;  ///< exact repeats of a track's row before them, dropped
  double sample_period = 0.0;
  int scans = 0;
};

/// The recorded tracks on their sample grid, cut into windows: a TrackSet with `recorded` set,
/// every window's recording in `recording`. Throws std::runtime_error naming the file, line and
/// column of the first problem; nothing is returned half-made.
[[nodiscard]] TrackSet import_recordings(const std::vector<RecordedTrack>& recordings,
                                         const ImportOptions& options, ImportReport* report);

/// read_recording of every file of `inputs` (a folder stands for its *.csv files, in name order),
/// then import_recordings: what `imm-data import` and Python's immtrain.import_recordings do.
/// Throws std::runtime_error naming the file (a folder without CSV files, a bad line).
[[nodiscard]] TrackSet import_recording_files(const std::vector<std::filesystem::path>& inputs,
                                              const ImportOptions& options, ImportReport* report);

/// The regime header an imported set is written with: name, units, sample period, scans and the
/// sensor kind, as TOML (what the data-set file's @config_toml records).
[[nodiscard]] Regime recording_header(const ImportOptions& options, const TrackSet& set);

/// Shuffles the recordings with a stream of `splits.seed` and deals them out: the first
/// `splits.training` to training, the next `splits.validation` to validation, the next
/// `splits.test` to test (a recording's windows stay together). With partial truth the recordings
/// with truth come first (in their shuffled order), and with recorded.truth = "evaluation" the
/// test split is dealt first, so the truth goes where the regime uses it.
void assign_recorded_splits(Recorded& recorded, const Splits& splits);

/// A recorded regime's split: the windows of its recordings, in the shuffled order (`count` ≥ 0
/// keeps the first `count`; more than the split holds is an InvalidParameter naming the split).
/// The training and validation splits carry truth only when the regime says recorded.truth =
/// "training" (otherwise their truth is NaN and has_truth false); the test split whenever the set
/// has it. With partial truth a window keeps its recording's; has_truth is true when every window
/// of the split has it (otherwise the split's recording_truth says which do).
[[nodiscard]] TrackSet recorded_split(const Regime& regime, Split split, int count = -1);
/// The windows a recorded regime's split holds.
[[nodiscard]] int recorded_split_size(const Regime& regime, Split split);
/// The largest plotted range of a polar set (the position σ of its azimuth noise).
[[nodiscard]] double recorded_max_range(const TrackSet& set);
/// Window `index` of a recorded regime's split.
[[nodiscard]] Track recorded_track(const Regime& regime, Split split, int index);

/// Writes track `index` of a set as a recording CSV (t, the plots, and the truth x, vx, y, vy
/// when `truth`), every number in shortest round-trip form: importing it gives the same bits.
void write_recording_csv(const std::filesystem::path& path, const TrackSet& set, SensorKind kind,
                         std::size_t index, bool truth);

}  // namespace imm::datasets
