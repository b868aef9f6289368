// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The exit codes of every tool (imm-train, imm-eval, imm-data, imm-track, imm-inspect), in one
/// place: the nightly reads imm-eval's and imm-train's codes, and scripts read all of them.

namespace imm::support::exit_code {

/// Success.
inline constexpr int kOk = 0;
/// The command line itself is wrong (CLI11: an unknown option, a value out of range).
inline constexpr int kUsage = 1;
/// A bad input: a config, model, data or CSV file refused, one line naming the file and the field;
/// or an output that cannot be written (a full disk).
inline constexpr int kBadInput = 2;
/// imm-train all / sweep: a nightly stage or a sweep's job failed (the others still ran).
inline constexpr int kJobFailed = 3;
/// imm-train <kind>: the trained model missed its config's quality gate (no model written).
inline constexpr int kTrainingGateFailed = 4;
/// imm-eval <experiment>: an evaluation's quality gate failed (its report is written).
inline constexpr int kEvaluationGateFailed = 5;
/// imm-eval regression: the candidate is worse than the shipped model beyond the interval.
inline constexpr int kRegression = 6;
/// imm-eval <experiment>: every gate passed, and the report has findings — the learned model does
/// not beat a baseline tuned on its regime. Reported with its numbers; not a failure (the nightly
/// promotes such a model and stays green).
inline constexpr int kFindings = 7;

}  // namespace imm::support::exit_code
