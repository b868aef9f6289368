#include "imm/datasets/range_sensor_file.hpp"

#include <cmath>
#include <cstdint>
#include <string>

#include "imm/datasets/dataset_file.hpp"
#include "imm/datasets/sha256.hpp"
#include "imm/io/container_file.hpp"
#include "imm/io/schema_reader.hpp"

namespace imm::datasets {

std::string digest(const RangeSensorData& data) {
  Sha256 hash;
  hash_matrix(hash, data.positions);
  hash_matrix(hash, data.outputs);
  return hash.hex_digest();
}

std::string digest(const CutInData& data) {
  Sha256 hash;
  hash_matrix(hash, data.truth);
  for (const auto& z : data.measurements) hash_matrix(hash, z);
  return hash.hex_digest();
}

std::string write_range_sensor_dataset(const std::filesystem::path& path,
                                       const RangeSensorDataConfig& config,
                                       const RangeSensorData& data, const std::string& config_toml,
                                       const std::string& generator_version) {
  config.validate();
  std::string data_digest = digest(data);
  io::ContainerWriter writer(path, kDatasetFormat);
  write_dataset_root(writer, "range_sensor", config.seed, config_toml, generator_version,
                     data_digest);
  writer.write("/positions", data.positions);
  writer.set_attribute("/positions", "columns", std::string("xi,eta"));
  writer.write("/outputs", data.outputs);
  writer.set_attribute("/outputs", "columns", std::string("z1,z2"));
  writer.set_attribute("/parameters", "knee", config.distortion.knee);
  writer.set_attribute("/parameters", "softness", config.distortion.softness);
  writer.set_attribute("/parameters", "noise_sigma", config.noise_sigma);
  writer.set_attribute("/parameters", "samples", std::int64_t{config.samples});
  Eigen::Matrix2d box;
  box.row(0) = config.lower.transpose();
  box.row(1) = config.upper.transpose();
  writer.write("/parameters/box", box);
  writer.set_attribute("/parameters/box", "columns", std::string("xi,eta"));
  writer.commit();
  return data_digest;
}

RangeSensorDataset read_range_sensor_dataset(const std::filesystem::path& path) {
  const io::SchemaReader reader(path, kDatasetFormat);
  check_dataset_header(reader, "range_sensor");
  RangeSensorDataset out;
  out.data.positions = reader.matrix("/positions", -1, 2);
  out.data.outputs = reader.matrix("/outputs", static_cast<int>(out.data.positions.rows()), 2);
  out.distortion.knee = reader.real("/parameters", "knee", io::ValueRule::kPositive);
  out.distortion.softness = reader.real("/parameters", "softness", io::ValueRule::kPositive);
  out.noise_sigma = reader.real("/parameters", "noise_sigma", io::ValueRule::kNonNegative);
  out.digest = reader.text("/", "digest");
  if (digest(out.data) != out.digest) {
    reader.fail("/@digest", "does not match the data (the file was altered)");
  }
  return out;
}

std::string write_cut_in_dataset(const std::filesystem::path& path, const CutInScenario& scenario,
                                 const CutInData& data, const std::string& config_toml,
                                 const std::string& generator_version) {
  scenario.validate();
  std::string data_digest = digest(data);
  io::ContainerWriter writer(path, kDatasetFormat);
  write_dataset_root(writer, "cut_in", scenario.seed, config_toml, generator_version, data_digest);
  writer.write("/truth", data.truth);
  writer.set_attribute("/truth", "columns", std::string("xi,vxi,axi,eta,veta,aeta"));
  writer.write("/measurements", stack_runs(data.measurements));
  writer.set_attribute("/measurements", "columns", std::string("z1,z2"));
  writer.set_attribute("/parameters", "sample_period", scenario.sample_period);
  writer.set_attribute("/parameters", "steps", std::int64_t{scenario.steps});
  writer.set_attribute("/parameters", "runs", std::int64_t{scenario.runs});
  writer.set_attribute("/parameters", "knee", scenario.distortion.knee);
  writer.set_attribute("/parameters", "softness", scenario.distortion.softness);
  writer.set_attribute("/parameters", "r_sigma_xi",
                       std::sqrt(scenario.measurement_covariance(0, 0)));
  writer.set_attribute("/parameters", "r_sigma_eta",
                       std::sqrt(scenario.measurement_covariance(1, 1)));
  writer.commit();
  return data_digest;
}

CutInDataset read_cut_in_dataset(const std::filesystem::path& path) {
  const io::SchemaReader reader(path, kDatasetFormat);
  check_dataset_header(reader, "cut_in");
  CutInDataset out;
  const auto steps = reader.integer("/parameters", "steps", 2, 10'000'000);
  const auto runs = reader.integer("/parameters", "runs", 1, 1'000'000);
  out.sample_period = reader.real("/parameters", "sample_period", io::ValueRule::kPositive);
  out.distortion.knee = reader.real("/parameters", "knee", io::ValueRule::kPositive);
  out.distortion.softness = reader.real("/parameters", "softness", io::ValueRule::kPositive);
  out.r_sigma =
      Eigen::Vector2d(reader.real("/parameters", "r_sigma_xi", io::ValueRule::kPositive),
                      reader.real("/parameters", "r_sigma_eta", io::ValueRule::kPositive));
  out.data.truth = reader.matrix("/truth", static_cast<int>(steps), 6);
  out.data.measurements = unstack_runs(reader.array("/measurements", {runs, steps, 2}));
  out.digest = reader.text("/", "digest");
  if (digest(out.data) != out.digest) {
    reader.fail("/@digest", "does not match the data (the file was altered)");
  }
  return out;
}

}  // namespace imm::datasets
