#include "imm/datasets/dataset_file.hpp"

#include "imm/core/invalid_parameter.hpp"
#include "imm/io/model_file.hpp"
#include "imm/io/schema_reader.hpp"

namespace imm::datasets {
namespace {

constexpr std::string_view kDatasetKind = "maneuver_scenario";

}  // namespace

void write_dataset_root(io::ContainerWriter& writer, std::string_view kind, std::uint64_t seed,
                        const std::string& config_toml, const std::string& generator_version,
                        const std::string& digest) {
  writer.set_attribute("/", "format", std::string(kDatasetFormat));
  writer.set_attribute("/", "schema_version", std::int64_t{kDatasetSchemaVersion});
  writer.set_attribute("/", "dataset_kind", std::string(kind));
  writer.set_attribute("/", "seed", static_cast<std::int64_t>(seed));
  writer.set_attribute("/", "created_utc", io::utc_now());
  writer.set_attribute("/", "generator_version", generator_version);
  writer.set_attribute("/", "config_toml", config_toml);
  writer.set_attribute("/", "digest", digest);
}

void check_dataset_header(const io::SchemaReader& reader, std::string_view kind) {
  const std::int64_t version = reader.integer("/", "schema_version", 1, INT64_MAX);
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

std::string write_scenario_dataset(const std::filesystem::path& path,
                                   const ManeuverScenario& scenario, const ScenarioData& data,
                                   const std::string& config_toml,
                                   const std::string& generator_version) {
  scenario.validate();
  std::string data_digest = digest(data);
  io::ContainerWriter writer(path, kDatasetFormat);
  write_dataset_root(writer, kDatasetKind, scenario.seed, config_toml, generator_version,
                     data_digest);
  writer.set_attribute("/", "scenario", scenario.name);

  writer.write("/time", io::Array::from_vector(data.time));
  writer.write("/acceleration_input", data.acceleration_input);
  writer.set_attribute("/acceleration_input", "columns", std::string("ax,ay"));
  writer.write("/truth", stack_runs(data.truth));
  writer.set_attribute("/truth", "columns", std::string("x,vx,y,vy"));
  writer.write("/measurements", stack_runs(data.measurements));
  writer.set_attribute(
      "/measurements", "columns",
      std::string(scenario.measurement.kind == MeasurementKind::kCartesian ? "zx,zy"
                                                                           : "range,azimuth"));

  writer.set_attribute("/parameters", "sample_period", scenario.sample_period);
  writer.set_attribute("/parameters", "steps", std::int64_t{scenario.steps});
  writer.set_attribute("/parameters", "runs", std::int64_t{scenario.runs});
  writer.set_attribute("/parameters", "process_noise_sigma", scenario.process_noise_sigma);
  writer.set_attribute("/parameters", "measurement_kind",
                       std::string(to_string(scenario.measurement.kind)));
  writer.set_attribute("/parameters", "measurement_sigma_0", scenario.measurement.sigma(0));
  writer.set_attribute("/parameters", "measurement_sigma_1", scenario.measurement.sigma(1));
  writer.write("/parameters/initial_state",
               io::Array::from_vector(
                   Eigen::Vector4d(scenario.initial_position(0), scenario.initial_velocity(0),
                                   scenario.initial_position(1), scenario.initial_velocity(1))));
  Eigen::MatrixXd maneuvers(static_cast<Eigen::Index>(scenario.maneuvers.size()), 4);
  for (std::size_t i = 0; i < scenario.maneuvers.size(); ++i) {
    const ManeuverSegment& m = scenario.maneuvers[i];
    maneuvers.row(static_cast<Eigen::Index>(i)) << m.start, m.end, m.acceleration(0),
        m.acceleration(1);
  }
  writer.write("/parameters/maneuvers", maneuvers);
  writer.set_attribute("/parameters/maneuvers", "columns", std::string("start,end,ax,ay"));
  Eigen::MatrixXd turns(static_cast<Eigen::Index>(scenario.turns.size()), 3);
  for (std::size_t i = 0; i < scenario.turns.size(); ++i) {
    const TurnSegment& t = scenario.turns[i];
    turns.row(static_cast<Eigen::Index>(i)) << t.start, t.end, t.omega;
  }
  writer.write("/parameters/turns", turns);
  writer.set_attribute("/parameters/turns", "columns", std::string("start,end,omega"));
  writer.commit();
  return data_digest;
}

ScenarioDataset read_scenario_dataset(const std::filesystem::path& path) {
  const io::SchemaReader reader(path, kDatasetFormat);
  check_dataset_header(reader, kDatasetKind);
  ScenarioDataset result;
  ManeuverScenario& s = result.scenario;
  s.name = reader.text("/", "scenario");
  s.seed = static_cast<std::uint64_t>(reader.integer("/", "seed", 0, INT64_MAX));
  result.created_utc = reader.text("/", "created_utc");
  result.generator_version = reader.text("/", "generator_version");
  result.config_toml = reader.text("/", "config_toml");
  result.digest = reader.text("/", "digest");

  s.sample_period = reader.real("/parameters", "sample_period", io::ValueRule::kPositive);
  s.steps = static_cast<int>(reader.integer("/parameters", "steps", 2, 10'000'000));
  s.runs = static_cast<int>(reader.integer("/parameters", "runs", 1, 1'000'000));
  s.process_noise_sigma =
      reader.real("/parameters", "process_noise_sigma", io::ValueRule::kNonNegative);
  try {
    s.measurement.kind =
        measurement_kind_from(reader.text("/parameters", "measurement_kind"), "measurement_kind");
  } catch (const InvalidParameter& error) {
    reader.fail("/parameters@measurement_kind", error.what());
  }
  s.measurement.sigma =
      Eigen::Vector2d(reader.real("/parameters", "measurement_sigma_0", io::ValueRule::kPositive),
                      reader.real("/parameters", "measurement_sigma_1", io::ValueRule::kPositive));
  const Eigen::VectorXd initial = reader.vector("/parameters/initial_state", 4);
  s.initial_position = Eigen::Vector2d(initial(0), initial(2));
  s.initial_velocity = Eigen::Vector2d(initial(1), initial(3));
  const Eigen::MatrixXd maneuvers = reader.matrix("/parameters/maneuvers", -1, 4);
  for (Eigen::Index i = 0; i < maneuvers.rows(); ++i) {
    s.maneuvers.push_back({static_cast<int>(maneuvers(i, 0)), static_cast<int>(maneuvers(i, 1)),
                           Eigen::Vector2d(maneuvers(i, 2), maneuvers(i, 3))});
  }
  if (reader.container().kind("/parameters/turns") == io::ObjectKind::kDataset) {
    const Eigen::MatrixXd turns = reader.matrix("/parameters/turns", -1, 3);
    for (Eigen::Index i = 0; i < turns.rows(); ++i) {
      s.turns.push_back(
          {static_cast<int>(turns(i, 0)), static_cast<int>(turns(i, 1)), turns(i, 2)});
    }
  }
  try {
    s.validate();
  } catch (const InvalidParameter& error) {
    reader.fail("/parameters", error.what());
  }

  const long steps = s.steps, runs = s.runs;
  result.data.time = reader.vector("/time", s.steps);
  result.data.acceleration_input = reader.matrix("/acceleration_input", s.steps, 2);
  result.data.truth = unstack_runs(reader.array("/truth", {runs, steps, 4}));
  result.data.measurements = unstack_runs(reader.array("/measurements", {runs, steps, 2}));
  if (digest(result.data) != result.digest) {
    reader.fail("/@digest", "does not match the stored data");
  }
  return result;
}

}  // namespace imm::datasets
