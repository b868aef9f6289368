// SPDX-License-Identifier: Apache-2.0
#pragma once
/// How a trainer writes a model file: into a temporary beside its name, committed (sealed) there,
/// finished by what the training command asks for (its covariance calibration and its envelope,
/// fitted on the written model: calibration.hpp, envelope.hpp), and only then renamed into place
/// with its folder synced. Under the model's name there is the old file or the whole finished one;
/// a trainer killed at any moment leaves at most a temporary that the next writer removes.

#include <filesystem>
#include <functional>

#include "imm/io/model_file.hpp"

namespace imm::trainer {

/// What is done to a committed model file before it appears under its name.
using ModelFinish = std::function<void(const std::filesystem::path& committed)>;

/// Sets the finish of every write_model_file of this thread for the scope's lifetime (the
/// training commands: calibrate the model they write); none outside one.
class ModelFinishScope {
 public:
  explicit ModelFinishScope(ModelFinish finish);
  ~ModelFinishScope();
  ModelFinishScope(const ModelFinishScope&) = delete;
  ModelFinishScope& operator=(const ModelFinishScope&) = delete;

 private:
  ModelFinish previous_;
};

/// Writes the model `write` puts into its writer as `out` (see the file comment). Throws what the
/// writer, `write` or the finish throws; `out` is then unchanged.
void write_model_file(const std::filesystem::path& out, io::Provenance provenance,
                      const std::function<void(io::ModelFileWriter&)>& write);

/// The training commands' finish: the covariance calibration (stored when it fits) and then the
/// envelope, each with its line in the log.
void calibrate_model_file(const std::filesystem::path& committed);

}  // namespace imm::trainer
