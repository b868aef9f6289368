// SPDX-License-Identifier: Apache-2.0
#pragma once
/// What an evaluation folder says of its model's quality gates: the SHA-256 of the model it
/// evaluated (metrics.json, the "evaluated" model) and the "Gates …: passed|FAILED" line of its
/// report.md with the failures listed under it. `imm-eval rank` reads them so that a learned model
/// whose own experiment failed its gates is never shipped as a regime's tracker.

#include <filesystem>
#include <span>
#include <string>
#include <vector>

namespace imm::evaluation {

struct EvaluationGates {
  std::filesystem::path folder;
  std::string model_sha256;  ///< the evaluated model file's
  /// The report's "Gates" line; empty when the experiment has no gates (nothing to fail).
  std::string line;
  bool passed = true;
  std::vector<std::string> failures;  ///< the "  - " lines under a FAILED gate, without the dash
};

/// Reads `folder`/metrics.json and `folder`/report.md. Throws std::runtime_error naming the file
/// and what is missing (a folder that is not a finished evaluation: no report.md, no evaluated
/// model, a Gates line that says neither "passed" nor "FAILED").
[[nodiscard]] EvaluationGates read_evaluation_gates(const std::filesystem::path& folder);

/// A learned model's standing against its own experiment's gates, from the evaluations given.
struct GateStanding {
  enum class State { kPassed, kFailed, kUnchecked } state = State::kUnchecked;
  std::string text;  ///< "passed (reports/x/)", "FAILED in reports/x/: …", "unchecked: …"
};

/// The standing of the model whose SHA-256 is `sha256`: failed when any evaluation of it failed
/// its gates, passed when at least one evaluated it and none failed, unchecked otherwise.
[[nodiscard]] GateStanding gate_standing(const std::string& sha256,
                                         std::span<const EvaluationGates> evaluations);

}  // namespace imm::evaluation
