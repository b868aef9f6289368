// SPDX-License-Identifier: Apache-2.0
#include "imm/datasets/range_sensor_file.hpp"

#include <array>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "imm/datasets/dataset_file.hpp"
#include "imm/datasets/sha256.hpp"
#include "imm/io/container_file.hpp"
#include "imm/io/file_error.hpp"
#include "imm/io/schema_reader.hpp"
#include "imm/support/csv.hpp"

namespace imm::datasets {

std::string digest(const RangeSensorData& data) {
  Sha256 hash;
  hash_matrix(hash, data.positions);
  hash_matrix(hash, data.outputs);
  return hash.hex_digest();
}

std::string write_range_sensor_dataset(const std::filesystem::path& path, const Regime& regime,
                                       const RangeSensorData& data, std::uint64_t seed,
                                       const std::string& generator_version) {
  std::string data_digest = digest(data);
  io::ContainerWriter writer(path, kDatasetFormat);
  write_dataset_root(writer, "range_sensor", seed, regime.text, generator_version, data_digest);
  writer.write("/positions", data.positions);
  writer.set_attribute("/positions", "columns", std::string("xi,eta"));
  writer.write("/outputs", data.outputs);
  writer.set_attribute("/outputs", "columns", std::string("z1,z2"));
  writer.set_attribute("/parameters", "regime", regime.name);
  writer.set_attribute("/parameters", "regime_digest", regime.digest);
  writer.set_attribute("/parameters", "noise_sigma", regime.sensor.calibration.noise_sigma);
  Eigen::Matrix2d box;
  box.row(0) = regime.sensor.calibration.lower.transpose();
  box.row(1) = regime.sensor.calibration.upper.transpose();
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
  out.regime = reader.text("/parameters", "regime");
  out.regime_digest = reader.text("/parameters", "regime_digest");
  out.digest = reader.text("/", "digest");
  if (digest(out.data) != out.digest) {
    reader.fail("/@digest", "does not match the data (the file was altered)");
  }
  return out;
}

RangeSensorData read_sensor_samples(const std::filesystem::path& path) {
  if (path.extension() != ".csv") return read_range_sensor_dataset(path).data;
  RangeSensorData samples;
  std::ifstream in(path);
  if (!in) throw io::FileError(path.string(), "", "cannot open");
  const std::string name = path.string();
  support::CsvReader reader(in, name);
  support::CsvLine line;
  std::vector<std::array<double, 4>> rows;
  static const std::vector<std::string_view> kColumns = {"xi", "eta", "z1", "z2"};
  while (reader.next(line)) {
    const auto fail = [&](const std::string& message) {
      throw io::FileError(reader.where(), "", message);
    };
    if (rows.empty() && !line.fields.empty() && line.fields.front() == "xi") {
      if (line.fields != kColumns) fail("header must be xi,eta,z1,z2");
      continue;
    }
    if (line.fields.size() != 4)
      fail("expected 4 fields (xi,eta,z1,z2), found " + std::to_string(line.fields.size()));
    std::array<double, 4> row{};
    for (std::size_t i = 0; i < 4; ++i) {
      const std::optional<double> value = support::parse_real(line.fields[i]);
      if (!value) {
        fail(std::string(kColumns[i]) + " ('" + std::string(line.fields[i]) +
             "') is not a finite number");
      }
      row[i] = *value;
    }
    rows.push_back(row);
  }
  if (rows.size() < 10) {
    throw io::FileError(name, "", "need at least 10 samples, found " + std::to_string(rows.size()));
  }
  samples.positions.resize(static_cast<Eigen::Index>(rows.size()), 2);
  samples.outputs.resize(static_cast<Eigen::Index>(rows.size()), 2);
  for (std::size_t q = 0; q < rows.size(); ++q) {
    const auto i = static_cast<Eigen::Index>(q);
    samples.positions.row(i) << rows[q][0], rows[q][1];
    samples.outputs.row(i) << rows[q][2], rows[q][3];
  }
  return samples;
}

}  // namespace imm::datasets
