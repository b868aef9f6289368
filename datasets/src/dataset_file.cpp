// SPDX-License-Identifier: Apache-2.0
#include "imm/datasets/dataset_file.hpp"

#include <cmath>
#include <limits>

#include "imm/io/model_file.hpp"
#include "imm/io/schema_reader.hpp"

namespace imm::datasets {
namespace {

constexpr std::string_view kDatasetKind = "tracks";

}  // namespace

void write_dataset_root(io::ContainerWriter& writer, std::string_view kind, std::uint64_t seed,
                        const std::string& config_toml, const std::string& generator_version,
                        const std::string& digest, int schema_version) {
  writer.set_attribute("/", "format", std::string(kDatasetFormat));
  writer.set_attribute("/", "schema_version", std::int64_t{schema_version});
  writer.set_attribute("/", "dataset_kind", std::string(kind));
  writer.set_attribute("/", "seed", static_cast<std::int64_t>(seed));
  writer.set_attribute("/", "created_utc", io::utc_now());
  writer.set_attribute("/", "generator_version", generator_version);
  writer.set_attribute("/", "config_toml", config_toml);
  writer.set_attribute("/", "digest", digest);
}

void check_dataset_header(const io::SchemaReader& reader, std::string_view kind) {
  const std::int64_t version = reader.integer("/", "schema_version", 1, INT64_MAX);
  if (version < kDrawnDatasetSchemaVersion) {
    reader.fail("/@schema_version", "schema version " + std::to_string(version) +
                                        " data sets (scenario-based) are not read any more; "
                                        "regenerate the file with imm-data");
  }
  if (version > kDatasetSchemaVersion) {
    reader.fail("/@schema_version", "schema version " + std::to_string(version) +
                                        " is newer than this reader supports (" +
                                        std::to_string(kDatasetSchemaVersion) + ")");
  }
  if (reader.text("/", "dataset_kind") != kind) {
    reader.fail("/@dataset_kind", "expected '" + std::string(kind) + "'");
  }
}

io::Array stack_runs(const std::vector<Eigen::MatrixXd>& runs) {
  io::Array array;
  const auto steps = static_cast<std::size_t>(runs.front().rows());
  const auto columns = static_cast<std::size_t>(runs.front().cols());
  array.shape = {runs.size(), steps, columns};
  array.values.reserve(runs.size() * steps * columns);
  for (const auto& run : runs) {
    for (Eigen::Index i = 0; i < run.rows(); ++i) {
      for (Eigen::Index j = 0; j < run.cols(); ++j) array.values.push_back(run(i, j));
    }
  }
  return array;
}

std::vector<Eigen::MatrixXd> unstack_runs(const io::Array& array) {
  const std::size_t runs = array.shape[0], steps = array.shape[1], columns = array.shape[2];
  std::vector<Eigen::MatrixXd> result;
  for (std::size_t r = 0; r < runs; ++r) {
    result.emplace_back(
        Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
            array.values.data() + r * steps * columns, static_cast<Eigen::Index>(steps),
            static_cast<Eigen::Index>(columns)));
  }
  return result;
}

std::string write_track_set(const std::filesystem::path& path, const Regime& regime,
                            const TrackSet& set, const std::string& generator_version) {
  if (set.tracks.empty()) throw io::FileError(path.string(), "/truth", "no tracks to write");
  if (!set.has_truth && !set.recorded) {
    throw io::FileError(path.string(), "/truth", "a drawn set always has its truth");
  }
  std::string data_digest = set.digest();
  io::ContainerWriter writer(path, kDatasetFormat);
  write_dataset_root(writer, kDatasetKind, set.seed, regime.text, generator_version, data_digest,
                     set.recorded ? kDatasetSchemaVersion : kDrawnDatasetSchemaVersion);
  // A recording's gaps are NaN plots and truth (and a recording without truth NaN truth).
  const auto values = set.recorded ? io::ContainerWriter::Values::kFiniteOrMissing
                                   : io::ContainerWriter::Values::kFinite;
  std::vector<Eigen::MatrixXd> truth, plots;
  Eigen::MatrixXd cases(static_cast<Eigen::Index>(set.tracks.size()), 4);
  std::vector<Eigen::MatrixXd> maneuvering;
  for (std::size_t i = 0; i < set.tracks.size(); ++i) {
    const Track& t = set.tracks[i];
    truth.push_back(t.truth);
    plots.push_back(t.plots);
    cases.row(static_cast<Eigen::Index>(i)) << t.case_index, t.noise.sigma(0), t.noise.sigma(1),
        t.noise.correlation;
    Eigen::MatrixXd flags(static_cast<Eigen::Index>(t.maneuvering.size()), 1);
    for (std::size_t k = 0; k < t.maneuvering.size(); ++k) {
      flags(static_cast<Eigen::Index>(k), 0) = t.maneuvering[k] ? 1.0 : 0.0;
    }
    maneuvering.push_back(std::move(flags));
  }
  if (set.has_truth || !set.recording_truth.empty()) {  // NaN for a recording without truth
    writer.write("/truth", stack_runs(truth), values);
    writer.set_attribute("/truth", "columns", std::string("x,vx,ax,y,vy,ay"));
  }
  if (set.recorded) {
    Eigen::MatrixXd recording(static_cast<Eigen::Index>(set.tracks.size()), 1);
    for (std::size_t i = 0; i < set.tracks.size(); ++i) {
      recording(static_cast<Eigen::Index>(i), 0) = set.recording.at(i);
    }
    writer.write("/recordings", recording);
    std::string names;
    for (const std::string& name : set.recording_names) names += name + '\n';
    writer.set_attribute("/parameters", "recording_names", names);
    writer.set_attribute("/parameters", "recorded", std::int64_t{1});
    writer.set_attribute("/parameters", "has_truth", std::int64_t{set.has_truth ? 1 : 0});
    if (!set.recording_truth.empty()) {  // partial truth: which recordings have it
      Eigen::MatrixXd flags(static_cast<Eigen::Index>(set.recording_truth.size()), 1);
      for (std::size_t r = 0; r < set.recording_truth.size(); ++r) {
        flags(static_cast<Eigen::Index>(r), 0) = set.recording_truth[r] ? 1.0 : 0.0;
      }
      writer.write("/recording_truth", flags);
    }
  }
  writer.write("/plots", stack_runs(plots), values);
  writer.set_attribute("/plots", "columns",
                       std::string(regime.sensor.kind == SensorKind::kPolar       ? "range,azimuth"
                                   : regime.sensor.kind == SensorKind::kCartesian ? "zx,zy"
                                                                                  : "z1,z2"));
  writer.write("/maneuvering", stack_runs(maneuvering));
  writer.write("/cases", cases);
  writer.set_attribute("/cases", "columns", std::string("case,sigma1,sigma2,correlation"));
  writer.set_attribute("/parameters", "regime", regime.name);
  writer.set_attribute("/parameters", "regime_digest", regime.digest);
  writer.set_attribute("/parameters", "split", std::string(to_string(set.split)));
  writer.set_attribute("/parameters", "sample_period", set.sample_period);
  writer.set_attribute("/parameters", "scans", std::int64_t{set.scans});
  writer.set_attribute("/parameters", "tracks", static_cast<std::int64_t>(set.tracks.size()));
  writer.set_attribute("/parameters", "units", std::string(to_string(regime.units)));
  writer.set_attribute("/parameters", "sensor", std::string(to_string(regime.sensor.kind)));
  writer.commit();
  return data_digest;
}

TrackSetFile read_track_set(const std::filesystem::path& path) {
  const io::SchemaReader reader(path, kDatasetFormat);
  check_dataset_header(reader, kDatasetKind);
  TrackSetFile result;
  TrackSet& set = result.set;
  set.seed = static_cast<std::uint64_t>(reader.integer("/", "seed", 0, INT64_MAX));
  result.created_utc = reader.text("/", "created_utc");
  result.generator_version = reader.text("/", "generator_version");
  result.regime_text = reader.text("/", "config_toml");
  result.digest = reader.text("/", "digest");
  set.regime = reader.text("/parameters", "regime");
  result.regime_digest = reader.text("/parameters", "regime_digest");
  const std::string split = reader.text("/parameters", "split");
  bool known = false;
  for (Split s : {Split::kTraining, Split::kValidation, Split::kTest}) {
    if (split == to_string(s)) set.split = s, known = true;
  }
  if (!known) reader.fail("/parameters@split", "unknown split '" + split + "'");
  set.sample_period = reader.real("/parameters", "sample_period", io::ValueRule::kPositive);
  set.scans = static_cast<int>(reader.integer("/parameters", "scans", 3, 1'000'000));
  const long tracks = reader.integer("/parameters", "tracks", 1, 1'000'000);
  const long scans = set.scans;
  result.units = reader.text("/parameters", "units");
  result.sensor = reader.text("/parameters", "sensor");
  const bool recorded = reader.container().attribute("/parameters", "recorded").has_value();
  // A recording's gaps are NaN plots (and NaN truth); a drawn set has no gap.
  const io::ValueRule values = recorded ? io::ValueRule::kFiniteOrMissing : io::ValueRule::kFinite;
  if (recorded) {
    set.recorded = true;
    set.has_truth = reader.integer("/parameters", "has_truth", 0, 1) == 1;
    const std::string names = reader.text("/parameters", "recording_names");
    for (std::size_t from = 0; from < names.size();) {
      const std::size_t end = names.find('\n', from);
      if (end == std::string::npos) reader.fail("/parameters@recording_names", "not newline-ended");
      set.recording_names.push_back(names.substr(from, end - from));
      from = end + 1;
    }
    const long count = static_cast<long>(set.recording_names.size());
    const Eigen::MatrixXd recording = reader.matrix("/recordings", static_cast<int>(tracks), 1);
    for (long i = 0; i < tracks; ++i) {
      const double r = recording(i, 0);
      if (!(r >= 0.0 && r < static_cast<double>(count) && r == std::floor(r))) {
        reader.fail("/recordings", "entry " + std::to_string(i) + " names no recording");
      }
      set.recording.push_back(static_cast<int>(r));
    }
    if (reader.container().kind("/recording_truth") != io::ObjectKind::kMissing) {
      const Eigen::MatrixXd flags = reader.matrix("/recording_truth", static_cast<int>(count), 1);
      for (long r = 0; r < count; ++r) {
        const double f = flags(r, 0);
        if (f != 0.0 && f != 1.0) reader.fail("/recording_truth", "entries must be 0 or 1");
        set.recording_truth.push_back(f == 1.0);
      }
      if (set.has_truth)
        reader.fail("/recording_truth", "a set with truth for all has no such flags");
    }
  }
  const auto truth =
      set.has_truth || !set.recording_truth.empty()
          ? unstack_runs(reader.array("/truth", {tracks, scans, 6}, values))
          : std::vector<Eigen::MatrixXd>(
                static_cast<std::size_t>(tracks),
                Eigen::MatrixXd::Constant(scans, 6, std::numeric_limits<double>::quiet_NaN()));
  const auto plots = unstack_runs(reader.array("/plots", {tracks, scans, 2}, values));
  const auto flags = unstack_runs(reader.array("/maneuvering", {tracks, scans, 1}));
  const Eigen::MatrixXd cases = reader.matrix("/cases", static_cast<int>(tracks), 4);
  for (long i = 0; i < tracks; ++i) {
    Track t;
    t.truth = truth[static_cast<std::size_t>(i)];
    t.plots = plots[static_cast<std::size_t>(i)];
    for (Eigen::Index k = 0; k < scans; ++k) {
      t.maneuvering.push_back(flags[static_cast<std::size_t>(i)](k, 0) != 0.0);
    }
    t.case_index = static_cast<int>(cases(i, 0));
    t.noise.sigma = Eigen::Vector2d(cases(i, 1), cases(i, 2));
    t.noise.correlation = cases(i, 3);
    set.tracks.push_back(std::move(t));
  }
  if (set.digest() != result.digest) reader.fail("/@digest", "does not match the stored data");
  return result;
}

}  // namespace imm::datasets
