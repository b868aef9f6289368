// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The bar a tracking engineer would set, in every experiment: the regime's classical IMM of CV,
/// CA and coordinated-turn modes (trainer/classical/classical_imm.hpp), tuned on the training
/// split of the model's regime with the search and budget of `imm-train baseline --config
/// configs/classical_imm.toml` — so it is the very filter that command ships for the regime —
/// and run on the experiment's test tracks beside its IMM-tuned, with NEES and NIS.

#include <Eigen/Core>
#include <array>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "imm/datasets/regime.hpp"
#include "imm/datasets/track.hpp"
#include "imm/evaluation/monte_carlo.hpp"
#include "imm/evaluation/uncertainty.hpp"
#include "imm/filters/plain_imm.hpp"

namespace imm::evaluation {

/// Its name in the experiments' tables.
inline constexpr std::string_view kClassicalBarName = "CT-IMM-tuned";

struct ClassicalBar {
  PlainImmSpec spec;
  /// Which modes, their intensities, the stay probability and the search's evaluations.
  std::string parameters;
  double training_objective = 0.0;  ///< ζ_p + ζ_v (or the excess NLL) on the training split
};

/// The classical bar of `own` (the model's regime), or nothing when its plots are neither
/// Cartesian nor polar (a range sensor's). With `file` (--classical), that model instead of a
/// search: a classical `plain_imm` file trained for `own` (std::runtime_error naming the file and
/// what differs otherwise).
[[nodiscard]] std::optional<ClassicalBar> tune_classical_bar(
    const datasets::Regime& own, const std::optional<std::filesystem::path>& file = std::nullopt);

/// `learned` and the classical bar of `own`, each run on the same test tracks: what an
/// experiment whose own tables are not 2-D tracks (per axis, per case) reports about the bar.
struct BarComparison {
  std::string parameters;               ///< the bar's (ClassicalBar::parameters)
  std::string length;                   ///< the regime's length unit
  std::vector<FilterOutcome> outcomes;  ///< the learned filter, then the bar
  /// The verdict's two criteria: ζ_p and ζ_v, or without truth the predictive NLL and the
  /// innovation RMS; each filter's values of them.
  std::array<std::string, 2> criteria;
  std::array<std::array<double, 2>, 2> values{};  ///< [filter][criterion]
  std::array<Difference, 2> differences;          ///< learned − bar, per criterion
  /// The position RMSE where the truth manoeuvres, each filter's, and its difference (with truth
  /// and manoeuvres only).
  std::array<double, 2> maneuver_rmse{};
  std::optional<Difference> maneuvers;
  std::string verdict;  ///< "beats", "ties" or "loses to"
  std::string summary;  ///< "<learned> <verdict> CT-IMM-tuned (ζ_p …, ζ_v …[, …])"

  /// The comparison as details.json records it ("versus_classical_bar").
  [[nodiscard]] nlohmann::json json() const;
};

/// The comparison of `learned` (run on `data`, plots around `sensor`) with the classical bar of
/// `own` (ClassicalBar; `file` as in tune_classical_bar); nothing when the regime has no bar.
[[nodiscard]] std::optional<BarComparison> compare_with_bar(
    const std::string& learned_name, const FilterFactory& learned, const TrackOptions& options,
    const datasets::Regime& own, const datasets::TrackSet& data, const Eigen::Vector2d& sensor,
    const std::optional<std::filesystem::path>& file = std::nullopt);

/// Prints `comparison` as "Against CT-IMM-tuned (the classical bar: …)": the two filters' criteria,
/// position RMSE overall and in manoeuvres, both consistencies, and the summary line.
void print_bar_comparison(const BarComparison& comparison);

/// compare_with_bar, printed; a learned model that does not beat the bar adds its summary to
/// `findings`. Returns BarComparison::json() (null without a bar).
[[nodiscard]] nlohmann::json compare_with_classical_bar(
    const std::string& learned_name, const FilterFactory& learned, const TrackOptions& options,
    const datasets::Regime& own, const datasets::TrackSet& data, const Eigen::Vector2d& sensor,
    std::vector<std::string>& findings,
    const std::optional<std::filesystem::path>& file = std::nullopt);

}  // namespace imm::evaluation
