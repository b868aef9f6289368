// SPDX-License-Identifier: Apache-2.0
// The nightly's comparison of a candidate with the shipped model: the copy of the shipped model it
// is evaluated beside, whether a candidate is news at all, and the headline metrics the manifest
// records (see nightly_model_stage.cpp for the path through them).
#include <map>
#include <sstream>

#include "imm/datasets/sha256.hpp"
#include "imm/io/model_file.hpp"
#include "imm/pipeline/registry.hpp"
#include "imm/trainer/provenance.hpp"
#include "nightly_run.hpp"

namespace imm::pipeline {

Night::ShippedSnapshot Night::snapshot_shipped(const NightlyStage& stage) {
  ShippedSnapshot snapshot;
  const RegistryEntry* entry = registry_.find(stage.name);
  const fs::path copy = registry_.staging_folder() / "shipped" / (stage.name + ".h5");
  const auto take = [&](const fs::path& source) {
    std::error_code error;
    if (!fs::is_regular_file(fs::symlink_status(source, error))) return std::string();
    fs::create_directories(copy.parent_path());
    fs::copy_file(source, copy, fs::copy_options::overwrite_existing);
    return datasets::file_sha256_hex(copy);
  };
  if (entry == nullptr) {
    // An unrecorded file (one that could not be adopted) is compared, but the promotion requires
    // that nothing is recorded under the name by then.
    if (!take(stage.out).empty()) snapshot.file = copy;
    return snapshot;
  }
  snapshot.sha256 = entry->sha256;
  for (const fs::path& source : {stage.out, registry_.archive_path(entry->sha256)}) {
    if (take(source) == entry->sha256) {
      snapshot.file = copy;
      return snapshot;
    }
  }
  // Neither the shipped file nor its archive copy is the manifest's model: nothing to compare with.
  snapshot.unavailable = true;
  fs::remove(copy);
  return snapshot;
}

bool Night::trained_for_another_regime(const fs::path& candidate, const fs::path& shipped) {
  try {
    const io::ModelFileReader a(candidate), b(shipped);
    return a.provenance().regime_digest != b.provenance().regime_digest;
  } catch (const std::exception&) {
    return false;  // a file that does not read says nothing: the gate fails closed
  }
}

std::optional<std::string> Night::no_news(const NightlyStage& stage, const fs::path& staging,
                                          const std::vector<const NightlyStage*>& evaluations) {
  const RegistryEntry* shipped = registry_.find(stage.name);
  if (shipped == nullptr || !fs::exists(stage.out) ||
      datasets::file_sha256_hex(stage.out) != shipped->sha256) {
    return std::nullopt;
  }
  ModelDifference difference;
  RegistryEntry candidate;
  try {
    difference = model_difference(staging, stage.out);
    candidate = describe_model(staging, plan_.registry, stage.name);
  } catch (const std::exception& error) {
    return std::nullopt;  // a file that does not read is no tie; the promotion says why
  }
  // A candidate that holds what the shipped file lacks (or the reverse) is news: a new field of
  // the file's content (its calibrated envelope, say), whatever its metrics.
  if (difference.kind == ModelDifference::Kind::kStructure) return std::nullopt;
  if (difference.same()) {
    return "the candidate is the shipped model (the same parameters to rounding; only its build "
           "and training date differ): " +
           stage.out.filename().string() + " stays byte for byte";
  }
  // A tie on every metric is no news when the model is trained from the same definition; a new
  // config, regime or schema is (the shipped file would no longer say how it was made).
  if (evaluations.empty() || candidate.kind != shipped->kind ||
      candidate.config_digest != shipped->config_digest ||
      candidate.regime_digest != shipped->regime_digest ||
      candidate.schema_version != shipped->schema_version) {
    return std::nullopt;
  }
  std::size_t metrics = 0;
  for (const NightlyStage* e : evaluations) {
    const fs::path regression = e->out / "regression.json";
    if (!fs::exists(regression)) return std::nullopt;  // not compared: no evidence of a tie
    const auto document = nlohmann::json::parse(trainer::read_text_file(regression));
    for (const auto& m : document.at("metrics")) {
      if (m.at("verdict").get<std::string>() != "tie") return std::nullopt;
      ++metrics;
    }
  }
  return "ties the shipped model in all " + std::to_string(metrics) +
         " headline metrics (within the interval or the plan's margin) and is trained from the "
         "same config and regime (" +
         difference.what + "): " + stage.out.filename().string() + " stays byte for byte";
}

nlohmann::json Night::headline_metrics(const std::vector<const NightlyStage*>& evaluations) {
  nlohmann::json metrics = nlohmann::json::object();
  for (const NightlyStage* e : evaluations) {
    const fs::path headline = e->out / "headline.json";
    if (!fs::exists(headline)) continue;
    const auto document = nlohmann::json::parse(trainer::read_text_file(headline));
    std::map<std::string, nlohmann::json> versus;
    if (fs::exists(e->out / "regression.json")) {
      const auto regression =
          nlohmann::json::parse(trainer::read_text_file(e->out / "regression.json"));
      for (const auto& m : regression.at("metrics")) versus[m.at("name")] = m;
    }
    for (const auto& m : document.at("metrics")) {
      const std::string name = e->name + ": " + m.at("name").get<std::string>();
      nlohmann::json entry = {{"value", m.at("value")},
                              {"interval", m.value("interval", nlohmann::json::array())}};
      const auto it = versus.find(m.at("name").get<std::string>());
      if (it != versus.end()) {
        std::ostringstream text;
        text.precision(4);
        text << std::showpos << it->second.at("difference").get<double>() << " ["
             << it->second.at("lower").get<double>() << ", " << it->second.at("upper").get<double>()
             << "]";
        entry["versus_previous"] = text.str();
      }
      metrics[name] = entry;
    }
  }
  return metrics;
}

}  // namespace imm::pipeline
