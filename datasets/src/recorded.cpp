// SPDX-License-Identifier: Apache-2.0
#include "imm/datasets/recorded.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include "imm/core/physical_limits.hpp"
#include "imm/support/csv.hpp"

namespace imm::datasets {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// The header's columns: where each known one is (or −1).
struct Columns {
  int t = -1, z1 = -1, z2 = -1, track = -1;
  int x = -1, vx = -1, y = -1, vy = -1;
  std::size_t count = 0;
  [[nodiscard]] bool truth() const { return x >= 0; }
};

Columns read_header(const support::CsvReader& reader, const support::CsvLine& line,
                    SensorKind kind) {
  const char* z1 = kind == SensorKind::kPolar       ? "range"
                   : kind == SensorKind::kCartesian ? "zx"
                                                    : "z1";
  const char* z2 = kind == SensorKind::kPolar       ? "azimuth"
                   : kind == SensorKind::kCartesian ? "zy"
                                                    : "z2";
  Columns c;
  c.count = line.fields.size();
  const std::map<std::string_view, int*> known = {{"t", &c.t},         {z1, &c.z1},  {z2, &c.z2},
                                                  {"track", &c.track}, {"x", &c.x},  {"vx", &c.vx},
                                                  {"y", &c.y},         {"vy", &c.vy}};
  for (std::size_t i = 0; i < line.fields.size(); ++i) {
    const auto found = known.find(line.fields[i]);
    const std::string where =
        "column " + std::to_string(i + 1) + " ('" + std::string(line.fields[i]) + "')";
    if (found == known.end()) {
      // A plot column of another sensor: say which --sensor reads it.
      const std::string_view name = line.fields[i];
      const std::string hint =
          name == "range" || name == "azimuth" ? "; polar plots: --sensor polar"
          : name == "zx" || name == "zy"       ? "; Cartesian plots: --sensor cartesian"
          : name == "z1" || name == "z2"       ? "; a range sensor's plots: --sensor range_sensor"
                                               : "";
      std::string message = "header: " + where + " is not a recording column (t, ";
      message.append(z1).append(", ").append(z2).append(", track, and truth x, vx, y, vy)");
      reader.fail(message.append(hint));
    }
    if (*found->second >= 0) reader.fail("header: " + where + " appears twice");
    *found->second = static_cast<int>(i);
  }
  for (const auto& [name, at] : {std::pair<const char*, int>{"t", c.t}, {z1, c.z1}, {z2, c.z2}}) {
    if (at < 0) reader.fail("header: the column '" + std::string(name) + "' is missing");
  }
  const int truth_columns = (c.x >= 0) + (c.vx >= 0) + (c.y >= 0) + (c.vy >= 0);
  if (truth_columns != 0 && truth_columns != 4) {
    reader.fail("header: truth needs all of x, vx, y, vy (or none)");
  }
  return c;
}

/// Field `column` of a row as a finite number, or a failure naming the line and the column.
double field(const support::CsvReader& reader, const support::CsvLine& line, int column,
             const Columns& columns) {
  const auto i = static_cast<std::size_t>(column);
  if (line.fields.size() != columns.count) {
    reader.fail("has " + std::to_string(line.fields.size()) + " columns, the header " +
                std::to_string(columns.count));
  }
  const std::optional<double> value = support::parse_real(line.fields[i]);
  if (!value) {
    reader.fail("column " + std::to_string(i + 1) + ": '" + std::string(line.fields[i]) +
                "' is not a finite number");
  }
  return *value;
}

/// Rows of one track as they are read, before they become matrices.
struct Rows {
  std::string name;
  std::vector<std::size_t> lines;
  std::vector<double> values;  // t, z1, z2 [, x, vx, y, vy] per row
};

std::string where(const RecordedTrack& track, std::size_t row) {
  return track.file + ":" + std::to_string(track.lines[row]);
}

// Drops every row of `rows` that repeats the row before it exactly (the same time and values, bit
// for bit), recording its line in `repeated`; a row at the same time with other values is refused
// naming both lines.
void drop_repeated_rows(Rows& rows, std::size_t width, const std::filesystem::path& path,
                        int time_column, std::vector<std::size_t>& repeated) {
  std::size_t kept = 0;
  for (std::size_t row = 0; row < rows.lines.size(); ++row) {
    const double* values = rows.values.data() + row * width;
    if (kept > 0) {
      const double* before = rows.values.data() + (kept - 1) * width;
      if (values[0] == before[0]) {
        if (std::memcmp(values, before, width * sizeof(double)) == 0) {
          repeated.push_back(rows.lines[row]);
          continue;
        }
        const std::string line = std::to_string(rows.lines[row]);
        const std::string earlier = std::to_string(rows.lines[kept - 1]);
        throw std::runtime_error(path.string() + ":" + line + ": column " +
                                 std::to_string(time_column + 1) + " ('t'): track '" + rows.name +
                                 "' has another plot at the time of line " + earlier);
      }
    }
    if (kept != row) {
      std::memmove(rows.values.data() + kept * width, values, width * sizeof(double));
      rows.lines[kept] = rows.lines[row];
    }
    ++kept;
  }
  rows.lines.resize(kept);
  rows.values.resize(kept * width);
}

}  // namespace

std::vector<RecordedTrack> read_recording(const std::filesystem::path& path,
                                          const RecordingFormat& format) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path.string() + ": cannot be read");
  support::CsvReader reader(in, path.string());
  support::CsvLine line;
  if (!reader.next(line)) throw std::runtime_error(path.string() + ":1: the file is empty");
  const Columns columns = read_header(reader, line, format.kind);
  const std::size_t width = columns.truth() ? 7 : 3;
  std::vector<Rows> tracks;
  std::map<std::string, std::size_t, std::less<>> index;
  while (reader.next(line)) {
    std::string name = path.stem().string();
    if (columns.track >= 0) {
      if (line.fields.size() != columns.count) field(reader, line, columns.t, columns);  // fails
      name = std::string(line.fields[static_cast<std::size_t>(columns.track)]);
      if (name.empty()) {
        reader.fail("column " + std::to_string(columns.track + 1) + " ('track') is empty");
      }
    }
    auto [at, fresh] = index.try_emplace(name, tracks.size());
    if (fresh) tracks.push_back(Rows{name, {}, {}});
    Rows& rows = tracks[at->second];
    rows.lines.push_back(line.number);
    for (int column : {columns.t, columns.z1, columns.z2}) {
      rows.values.push_back(field(reader, line, column, columns));
    }
    if (columns.truth()) {
      for (int column : {columns.x, columns.vx, columns.y, columns.vy}) {
        rows.values.push_back(field(reader, line, column, columns));
      }
    }
  }
  if (tracks.empty()) throw std::runtime_error(path.string() + ": no plots after the header");
  std::vector<RecordedTrack> result;
  for (Rows& rows : tracks) {
    RecordedTrack track;
    track.name = rows.name;
    track.file = path.string();
    drop_repeated_rows(rows, width, path, columns.t, track.repeated_lines);
    track.lines = std::move(rows.lines);
    const auto n = static_cast<Eigen::Index>(track.lines.size());
    const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>
        values(rows.values.data(), n, static_cast<Eigen::Index>(width));
    track.times = values.col(0);
    track.plots = values.middleCols(1, 2);
    track.truth =
        columns.truth() ? Eigen::MatrixXd(values.middleCols(3, 4)) : Eigen::MatrixXd(n, 0);
    for (Eigen::Index k = 1; k < n; ++k) {
      if (!(track.times(k) > track.times(k - 1))) {
        throw std::runtime_error(where(track, static_cast<std::size_t>(k)) + ": column " +
                                 std::to_string(columns.t + 1) + " ('t'): the times of track '" +
                                 track.name + "' must increase");
      }
    }
    result.push_back(std::move(track));
  }
  return result;
}

TrackSet import_recordings(const std::vector<RecordedTrack>& recordings,
                           const ImportOptions& options, ImportReport* report) {
  if (recordings.empty()) throw std::runtime_error("no recorded tracks to import");
  if (!(options.tolerance > 0.0 && options.tolerance < 0.5)) {
    throw std::runtime_error("the tolerance must be in (0, 0.5) of a sample period");
  }
  // Truth for every recording, none, or some (partial truth: TrackSet::recording_truth).
  std::size_t with_truth = 0;
  for (const RecordedTrack& r : recordings) with_truth += r.truth.cols() == 4 ? 1 : 0;
  double T = options.sample_period;
  if (T == 0.0) {  // the median step of the first track with two plots
    for (const RecordedTrack& r : recordings) {
      if (r.times.size() < 2) continue;
      std::vector<double> steps(static_cast<std::size_t>(r.times.size() - 1));
      for (std::size_t k = 0; k < steps.size(); ++k) {
        steps[k] =
            r.times(static_cast<Eigen::Index>(k) + 1) - r.times(static_cast<Eigen::Index>(k));
      }
      std::nth_element(steps.begin(), steps.begin() + static_cast<long>(steps.size() / 2),
                       steps.end());
      T = steps[steps.size() / 2];
      break;
    }
  }
  if (options.sample_period != 0.0) {
    // NaN is not 0: a period given is held to a sample period's limits (1 µs to 10 h).
    limits::require_in(options.sample_period, limits::kSamplePeriod, "sample_period");
  } else if (!(T > 0.0 && std::isfinite(T))) {
    throw std::runtime_error("the sample period is unknown: no track has two plots");
  } else if (!limits::contains(limits::kSamplePeriod, T)) {
    std::ostringstream message;
    message << "the first track's median step, " << T << " s, is not a sample period ("
            << limits::describe(limits::kSamplePeriod) << "): give the sample period";
    throw std::runtime_error(message.str());
  }
  // Every track on its grid: k = (t − t₀)/T within the tolerance.
  std::vector<std::vector<Eigen::Index>> grid(recordings.size());
  Eigen::Index shortest = std::numeric_limits<Eigen::Index>::max(), total = 0;
  ImportReport local;
  for (std::size_t r = 0; r < recordings.size(); ++r) {
    const RecordedTrack& track = recordings[r];
    for (Eigen::Index k = 0; k < track.times.size(); ++k) {
      const double periods = (track.times(k) - track.times(0)) / T;
      const double whole = std::round(periods);
      if (whole >= 1e6) {  // a regime's scans are at most 10⁶ (and a hostile time a grid's size)
        throw std::runtime_error(where(track, static_cast<std::size_t>(k)) +
                                 ": column 't': more than 10⁶ sample periods after the track's "
                                 "first plot");
      }
      if (std::abs(periods - whole) > options.tolerance) {
        std::ostringstream message;
        message.precision(10);
        message << where(track, static_cast<std::size_t>(k)) << ": column 't': " << track.times(k)
                << " s is " << periods << " sample periods of " << T
                << " s after the track's first plot, not a whole number within "
                << options.tolerance
                << ": the sample period changed, or the time stamps jitter by more than the "
                   "tolerance (a larger one, below 0.5, takes them: imm-data import --tolerance)";
        throw std::runtime_error(message.str());
      }
      const auto scan = static_cast<Eigen::Index>(whole);
      if (k > 0 && scan == grid[r].back()) {
        throw std::runtime_error(where(track, static_cast<std::size_t>(k)) +
                                 ": column 't': two plots on one scan of " + std::to_string(T) +
                                 " s");
      }
      grid[r].push_back(scan);
    }
    shortest = std::min(shortest, grid[r].back() + 1);
    total += grid[r].back() + 1;
    if (total > 10'000'000) {  // gaps make a grid longer than its rows: bound what it allocates
      throw std::runtime_error(track.file + ": track '" + track.name +
                               "': the recordings span more than 10⁷ scans with their gaps");
    }
  }
  const int scans = options.scans > 0 ? options.scans : static_cast<int>(shortest);
  if (scans < 3)
    throw std::runtime_error("a window needs at least 3 scans; the shortest track has " +
                             std::to_string(shortest));
  TrackSet set;
  set.regime = options.name;
  set.split = Split::kTest;
  set.sample_period = T;
  set.scans = scans;
  set.recorded = true;
  set.has_truth = with_truth == recordings.size();
  if (with_truth > 0 && with_truth < recordings.size()) {
    for (const RecordedTrack& r : recordings) set.recording_truth.push_back(r.truth.cols() == 4);
  }
  for (std::size_t r = 0; r < recordings.size(); ++r) {
    const RecordedTrack& track = recordings[r];
    const bool truth = track.truth.cols() == 4;
    const Eigen::Index length = grid[r].back() + 1;
    // The track on its grid: NaN where a scan has no plot.
    Eigen::MatrixXd plots = Eigen::MatrixXd::Constant(length, 2, kNaN);
    Eigen::MatrixXd states = Eigen::MatrixXd::Constant(length, 4, kNaN);
    for (std::size_t k = 0; k < grid[r].size(); ++k) {
      plots.row(grid[r][k]) = track.plots.row(static_cast<Eigen::Index>(k));
      if (truth) states.row(grid[r][k]) = track.truth.row(static_cast<Eigen::Index>(k));
    }
    local.gap_scans += static_cast<long>(length) - static_cast<long>(grid[r].size());
    local.repeated_lines += static_cast<long>(track.repeated_lines.size());
    set.recording_names.push_back(track.name);
    const Eigen::Index windows = length / scans;
    local.dropped_scans += static_cast<long>(length - windows * scans);
    for (Eigen::Index w = 0; w < windows; ++w) {
      Track window;
      window.plots = plots.middleRows(w * scans, scans);
      window.truth = Eigen::MatrixXd::Constant(scans, 6, kNaN);
      if (truth) {
        const Eigen::MatrixXd s = states.middleRows(w * scans, scans);
        for (Eigen::Index k = 0; k < scans; ++k) {
          const Eigen::Index next = k + 1 < scans ? k + 1 : k, from = k + 1 < scans ? k : k - 1;
          window.truth.row(k) << s(k, 0), s(k, 1), (s(next, 1) - s(from, 1)) / T, s(k, 2), s(k, 3),
              (s(next, 3) - s(from, 3)) / T;
        }
      }
      window.maneuvering.assign(static_cast<std::size_t>(scans), false);
      window.case_index = 0;
      window.noise.sigma.setZero();  // not known: the regime states or learns it
      set.tracks.push_back(std::move(window));
      set.recording.push_back(static_cast<int>(r));
    }
  }
  if (set.tracks.empty()) throw std::runtime_error("no track is as long as one window");
  local.recordings = static_cast<int>(recordings.size());
  local.windows = static_cast<int>(set.tracks.size());
  local.sample_period = T;
  local.scans = scans;
  if (report != nullptr) *report = local;
  return set;
}

Regime recording_header(const ImportOptions& options, const TrackSet& set) {
  Regime header;
  header.name = options.name;
  header.units = options.units;
  header.sample_period = set.sample_period;
  header.scans = set.scans;
  header.sensor.kind = options.kind;
  std::ostringstream text;
  text.precision(17);
  text << "# a recorded track set (imm-data import)\nname = \"" << options.name << "\"\nunits = \""
       << to_string(options.units) << "\"\nsample_period = " << set.sample_period
       << "\nscans = " << set.scans << "\n[sensor]\nkind = \"" << to_string(options.kind) << "\"\n";
  header.text = text.str();
  return header;
}

void write_recording_csv(const std::filesystem::path& path, const TrackSet& set, SensorKind kind,
                         std::size_t index, bool truth) {
  const Track& track = set.tracks.at(index);
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error(path.string() + ": cannot be written");
  out << (kind == SensorKind::kPolar       ? "t,range,azimuth"
          : kind == SensorKind::kCartesian ? "t,zx,zy"
                                           : "t,z1,z2");
  if (truth) out << ",x,vx,y,vy";
  out << '\n';
  char buffer[32];
  auto put = [&](double value) {
    const auto end = std::to_chars(buffer, buffer + sizeof buffer, value).ptr;
    out.write(buffer, end - buffer);
  };
  for (Eigen::Index k = 0; k < track.plots.rows(); ++k) {
    if (!track.plots.row(k).allFinite()) continue;  // a gap stays a gap
    put(static_cast<double>(k) * set.sample_period);
    for (Eigen::Index j = 0; j < 2; ++j) out << ',', put(track.plots(k, j));
    if (truth) {
      for (Eigen::Index j : {0, 1, 3, 4}) out << ',', put(track.truth(k, j));
    }
    out << '\n';
  }
  if (!out.flush()) throw std::runtime_error(path.string() + ": write failed");
}

TrackSet import_recording_files(const std::vector<std::filesystem::path>& inputs,
                                const ImportOptions& options, ImportReport* report) {
  // A folder stands for its *.csv files, in name order.
  std::vector<std::filesystem::path> files;
  for (const std::filesystem::path& input : inputs) {
    if (!std::filesystem::is_directory(input)) {
      files.push_back(input);
      continue;
    }
    std::vector<std::filesystem::path> inside;
    for (const auto& entry : std::filesystem::directory_iterator(input)) {
      if (entry.is_regular_file() && entry.path().extension() == ".csv") {
        inside.push_back(entry.path());
      }
    }
    if (inside.empty()) throw std::runtime_error(input.string() + ": no .csv files in the folder");
    std::sort(inside.begin(), inside.end());
    files.insert(files.end(), inside.begin(), inside.end());
  }
  std::vector<RecordedTrack> tracks;
  for (const auto& file : files) {
    for (auto& track : read_recording(file, {options.kind})) tracks.push_back(std::move(track));
  }
  return import_recordings(tracks, options, report);
}

}  // namespace imm::datasets
