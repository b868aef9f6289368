// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/model_files/write_model.hpp"

#include <spdlog/spdlog.h>

#include <system_error>
#include <utility>

#include "imm/io/temporary_files.hpp"
#include "imm/trainer/model_files/calibration.hpp"
#include "imm/trainer/model_files/envelope.hpp"
#include "imm/trainer/provenance.hpp"

namespace imm::trainer {
namespace {

thread_local ModelFinish
    current_finish;  // NOLINT(cppcoreguidelines-avoid-non-const-global-variables)

}  // namespace

ModelFinishScope::ModelFinishScope(ModelFinish finish) : previous_(std::move(current_finish)) {
  current_finish = std::move(finish);
}

ModelFinishScope::~ModelFinishScope() { current_finish = std::move(previous_); }

void write_model_file(const std::filesystem::path& out, io::Provenance provenance,
                      const std::function<void(io::ModelFileWriter&)>& write) {
  ensure_parent_folder(out);
  if (!current_finish) {  // nothing to finish: the writer's own commit is the one rename
    io::ModelFileWriter writer(out, std::move(provenance));
    write(writer);
    writer.commit();
    return;
  }
  const std::filesystem::path staged = io::temporary_beside(out, 2U);
  try {
    io::ModelFileWriter writer(staged, std::move(provenance));
    write(writer);
    writer.commit();
    current_finish(staged);
  } catch (...) {
    std::error_code ignored;
    std::filesystem::remove(staged, ignored);
    throw;
  }
  move_atomically(staged, out);  // the finished file on disk before its name is
}

void calibrate_model_file(const std::filesystem::path& committed) {
  const CalibrationFit fit = fit_calibration(committed);
  spdlog::info("{}", describe(fit));
  if (fit.fitted) store_calibration(committed, fit.calibration);
  spdlog::info("{}", describe(calibrate_and_store_envelope(committed)));
}

}  // namespace imm::trainer
