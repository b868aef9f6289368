// SPDX-License-Identifier: Apache-2.0
#include "imm/evaluation/evaluation_gates.hpp"

#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "imm/trainer/provenance.hpp"

namespace imm::evaluation {

EvaluationGates read_evaluation_gates(const std::filesystem::path& folder) {
  EvaluationGates gates;
  gates.folder = folder;
  const std::filesystem::path metrics = folder / "metrics.json";
  const std::filesystem::path report = folder / "report.md";
  for (const auto& file : {metrics, report}) {
    if (!std::filesystem::is_regular_file(file)) {
      throw std::runtime_error(file.string() +
                               ": missing (not the folder of a finished imm-eval evaluation)");
    }
  }
  nlohmann::json json;
  try {
    json = nlohmann::json::parse(trainer::read_text_file(metrics));
  } catch (const nlohmann::json::exception& error) {
    throw std::runtime_error(metrics.string() + ": not JSON (" + error.what() + ")");
  }
  if (json.is_object() && json.contains("models") && json["models"].is_array()) {
    for (const auto& model : json["models"]) {
      if (model.is_object() && model.value("role", "") == "evaluated" && model.contains("sha256") &&
          model["sha256"].is_string()) {
        gates.model_sha256 = model["sha256"].get<std::string>();
      }
    }
  }
  if (gates.model_sha256.size() != 64) {
    throw std::runtime_error(metrics.string() +
                             ": models: names no evaluated model with its sha256");
  }
  std::ifstream in(report);
  bool inside = false;
  for (std::string line; std::getline(in, line);) {
    if (line.starts_with("Gates")) {
      if (!gates.line.empty()) {
        throw std::runtime_error(report.string() + ": more than one Gates line");
      }
      gates.line = line;
      const bool failed = line.ends_with(": FAILED");
      if (!failed && !line.ends_with(": passed")) {
        throw std::runtime_error(report.string() + ": the Gates line says neither passed nor " +
                                 "FAILED: " + line.substr(0, 200));
      }
      gates.passed = !failed;
      inside = failed;
    } else if (inside && line.starts_with("  - ")) {
      gates.failures.push_back(line.substr(4));
    } else {
      inside = false;
    }
  }
  return gates;
}

GateStanding gate_standing(const std::string& sha256,
                           std::span<const EvaluationGates> evaluations) {
  GateStanding standing;
  std::string passed_in;
  for (const EvaluationGates& e : evaluations) {
    if (e.model_sha256 != sha256) continue;
    if (!e.passed) {
      standing.state = GateStanding::State::kFailed;
      standing.text =
          "FAILED in " + e.folder.string() +
          (e.failures.empty() ? std::string() : ": " + e.failures.front()) +
          (e.failures.size() > 1 ? " (and " + std::to_string(e.failures.size() - 1) + " more)"
                                 : std::string());
      return standing;
    }
    passed_in +=
        (passed_in.empty() ? "" : ", ") + e.folder.string() + (e.line.empty() ? " (no gates)" : "");
  }
  if (!passed_in.empty()) {
    standing.state = GateStanding::State::kPassed;
    standing.text = "passed (" + passed_in + ")";
  } else {
    standing.text = "unchecked: no evaluation of this file given (--evaluations)";
  }
  return standing;
}

}  // namespace imm::evaluation
