// SPDX-License-Identifier: Apache-2.0
#pragma once
// The nightly's stage cache: what every stage read (its tool, arguments and the bytes of the files
// they name) as one digest, and the outcome and outputs of its last run by that digest, so that an
// unchanged stage is not run again. Not installed.

#include <filesystem>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "imm/datasets/sha256.hpp"
#include "imm/pipeline/nightly.hpp"
#include "imm/trainer/provenance.hpp"

namespace imm::pipeline {

namespace fs = std::filesystem;

/// SHA-256 of files, each computed once per night.
class Digests {
 public:
  std::string of_file(const fs::path& path) {
    const std::string key = fs::absolute(path).lexically_normal().string();
    auto it = cache_.find(key);
    if (it != cache_.end()) return it->second;
    return cache_[key] = datasets::file_sha256_hex(path);
  }
  void forget(const fs::path& path) {
    cache_.erase(fs::absolute(path).lexically_normal().string());
  }

 private:
  std::map<std::string, std::string> cache_;
};

// Everything a stage reads: its tool, the project's libraries, the texts of its arguments and the
// inputs the plan declared for it (NightlyStage::inputs, StageInput: a file's bytes, a trainer
// config's and its regime's, an import's recordings, an evaluation's model folder, a candidate's
// verdict).
// A model file that a stage of the plan produces stands for that stage's inputs in another
// stage's digest (its bytes change with every retraining: the training date is in them), and
// counts whether or not it exists yet, so that the first night a new model appears does not
// change the digests of the stages before it.
using PlanOutputs = std::map<std::string, std::string>;  // normalized file → stage digest

/// The project's shared libraries this process loaded ("libimm…", e.g. the runtime when it is built
/// shared): the tools of the same build load the same files, so every stage digest includes them.
[[nodiscard]] std::vector<fs::path> project_libraries();

/// The absolute, lexically normal form of a path: how the digests name files.
[[nodiscard]] std::string normal_path(const fs::path& path);

/// The digest of everything `stage` reads (see above); `extra` adds texts (the evaluations' own
/// digests, for a model stage).
[[nodiscard]] std::string inputs_digest(const NightlyStage& stage, const fs::path& tool,
                                        Digests& digests,
                                        const std::vector<std::string>& extra = {},
                                        const PlanOutputs& plan_outputs = {});

struct CacheRecord {
  std::string inputs;
  StageOutcome outcome;
  std::map<std::string, std::string> outputs;  // file → sha256
};

class StageCache {
 public:
  explicit StageCache(fs::path path) : path_(std::move(path)) {
    if (!fs::exists(path_)) return;
    try {
      const auto document = nlohmann::json::parse(trainer::read_text_file(path_));
      for (const auto& [key, r] : document.at("stages").items()) {
        CacheRecord record;
        record.inputs = r.at("inputs").get<std::string>();
        record.outcome.status = r.at("status").get<std::string>();
        record.outcome.failed = r.at("failed").get<bool>();
        record.outcome.held_back = r.at("held_back").get<bool>();
        record.outcome.finding = r.value("finding", false);
        record.outcome.known_failure = r.value("known_failure", false);
        record.outcome.exit_code = r.at("exit_code").get<int>();
        record.outcome.message = r.at("message").get<std::string>();
        record.outcome.command = r.at("command").get<std::string>();
        record.outcome.report = r.value("report", "");
        record.outcome.regression = r.value("regression", "");
        record.outcome.night = r.at("night").get<std::string>();
        record.outcome.wall_seconds = r.value("wall_seconds", 0.0);
        record.outputs = r.at("outputs").get<std::map<std::string, std::string>>();
        records_[key] = std::move(record);
      }
    } catch (const std::exception& error) {
      std::cerr << "imm-train: ignoring an unreadable stage cache " << path_.string() << " ("
                << error.what() << ")\n";
      records_.clear();
    }
  }

  // The cached outcome when the inputs match and every output is still what the stage wrote.
  std::optional<StageOutcome> find(const std::string& key, const std::string& inputs,
                                   Digests& digests) const {
    const auto it = records_.find(key);
    if (it == records_.end() || it->second.inputs != inputs) return std::nullopt;
    for (const auto& [file, sha] : it->second.outputs) {
      if (!fs::is_regular_file(file) || digests.of_file(file) != sha) return std::nullopt;
    }
    StageOutcome outcome = it->second.outcome;
    outcome.cached = true;
    outcome.status = "cached: " + outcome.status;
    outcome.wall_seconds = 0.0;
    outcome.log.clear();
    return outcome;
  }

  // How long the stage ran the last time it ran, whatever its inputs were then.
  std::optional<double> last_seconds(const std::string& key) const {
    const auto it = records_.find(key);
    if (it == records_.end() || !(it->second.outcome.wall_seconds > 0.0)) return std::nullopt;
    return it->second.outcome.wall_seconds;
  }

  // Only an outcome that follows from the inputs is kept: a transient one (StageOutcome::transient,
  // or a tool killed by a signal: exit code above 128, or one that did not start) drops the
  // stage's record, so the next night runs it again instead of replaying the accident.
  void store(const std::string& key, const std::string& inputs, const StageOutcome& outcome,
             const std::vector<fs::path>& outputs, Digests& digests) {
    if (outcome.transient || outcome.exit_code > 128 || outcome.exit_code < 0) {
      if (records_.erase(key) > 0) save();
      return;
    }
    CacheRecord record{inputs, outcome, {}};
    for (const auto& f : outputs) {
      if (!fs::is_regular_file(f)) continue;
      digests.forget(f);
      record.outputs[f.string()] = digests.of_file(f);
    }
    records_[key] = std::move(record);
    save();
  }

 private:
  void save() const {
    nlohmann::json stages = nlohmann::json::object();
    for (const auto& [key, r] : records_) {
      stages[key] = {{"inputs", r.inputs},
                     {"status", r.outcome.status},
                     {"failed", r.outcome.failed},
                     {"held_back", r.outcome.held_back},
                     {"finding", r.outcome.finding},
                     {"known_failure", r.outcome.known_failure},
                     {"exit_code", r.outcome.exit_code},
                     {"message", r.outcome.message},
                     {"command", r.outcome.command},
                     {"report", r.outcome.report.string()},
                     {"regression", r.outcome.regression.string()},
                     {"night", r.outcome.night},
                     {"wall_seconds", r.outcome.wall_seconds},
                     {"outputs", r.outputs}};
    }
    trainer::write_json_atomically(path_, {{"stages", stages}});
  }

  fs::path path_;
  std::map<std::string, CacheRecord> records_;
};

}  // namespace imm::pipeline
