// SPDX-License-Identifier: Apache-2.0
// Fuzz target: the TOML config loaders — every trainer's (ga, mlp, tsk, fcm, wimm, with the regime
// given as the command line's --regime would, so the rest of the file is read), imm-track's plain
// IMM, the nightly plan and the regime file itself — on the same text.
//
// Findings: a crash, a hang, a sanitizer report, or an exception other than ConfigError (a
// FileError for a file the config names is allowed), or an unusable error message.

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

#include "fuzz/fuzz_support.hpp"
#include "imm/datasets/regime_file.hpp"
#include "imm/io/file_error.hpp"
#include "imm/pipeline/nightly.hpp"
#include "imm/support/config.hpp"
#include "imm/support/plain_imm_config.hpp"
#include "imm/trainer/fcm/fcm_trainer.hpp"
#include "imm/trainer/ga/ga_config.hpp"
#include "imm/trainer/mlp/mlp_trainer.hpp"
#include "imm/trainer/tsk/tsk_trainer.hpp"
#include "imm/trainer/wimm/wimm_trainer.hpp"

namespace {

std::filesystem::path regime(const char* name) {
  return std::filesystem::path(IMM_SOURCE_DIR) / "configs/regimes/paper" / name;
}

template <class Load>
void load_expecting_config_errors(std::string_view loader, Load&& load) {
  try {
    load();
  } catch (const imm::support::ConfigError& error) {
    imm::fuzz::expect_usable_message(error.what(), loader);
  } catch (const imm::io::FileError& error) {
    imm::fuzz::expect_usable_message(error.what(), loader);
  } catch (const std::exception& error) {
    imm::fuzz::finding(std::string(loader) + ": not a ConfigError: " + error.what());
  }
}

}  // namespace

// NOLINTNEXTLINE(readability-identifier-naming): the entry point libFuzzer calls
extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace imm;
  static const fuzz::ScratchFile file("config.toml");
  const std::string text(reinterpret_cast<const char*>(data), size);
  file.write(text);
  const std::filesystem::path& path = file.path();
  load_expecting_config_errors(
      "ga", [&] { (void)trainer::ga::load_ga_config(path, regime("ga_imm_training.toml")); });
  load_expecting_config_errors("mlp", [&] {
    (void)trainer::mlp::load_mlp_config(path, regime("input_estimator_training.toml"));
  });
  load_expecting_config_errors(
      "tsk", [&] { (void)trainer::tsk::load_tsk_config(path, regime("fimm_table1.toml")); });
  load_expecting_config_errors(
      "fcm", [&] { (void)trainer::fcm::load_fcm_config(path, regime("fcm_imm_training.toml")); });
  load_expecting_config_errors(
      "wimm", [&] { (void)trainer::wimm::load_wimm_config(path, regime("wimm_training.toml")); });
  load_expecting_config_errors("plain imm", [&] { (void)support::load_plain_imm_config(path); });
  load_expecting_config_errors("nightly", [&] { (void)pipeline::load_nightly_plan(path); });
  load_expecting_config_errors("regime", [&] { (void)datasets::parse_regime(text, "fuzz"); });
  return 0;
}
