// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Where the learned kinds' learning curves flatten: the number of training tracks from which the
/// validation gain of a learned part over the baseline it is built on stops growing, measured on
/// the shipped regimes by scripts/learning_curves.py (the curves are in docs/methods.md). A learned
/// part that switched itself off on a smaller training split may have been starved of data rather
/// than useless, and the trainer says so.

#include <optional>
#include <string>
#include <string_view>

namespace imm::trainer {

/// The training split size at which `kind`'s curve flattens ("ga": the GA's tables on the tuned
/// IMM, "fcm": the FCM compensation, "schedule": the noise schedules on the tuned CV/CA/CT IMM,
/// whose agile_air gain went −1.6 % at 24 tracks to −9.6 % at 48 and 96), or nothing for a kind
/// whose gain does not grow with the split on any shipped regime (the wIMM's fusion stayed off from
/// 6 to 48 tracks).
[[nodiscard]] inline std::optional<int> curve_flattens_at(std::string_view kind) {
  if (kind == "ga" || kind == "fcm") return 24;
  if (kind == "schedule") return 48;
  return std::nullopt;
}

/// The warning of a trainer whose learned part switched off on `training_tracks` training tracks,
/// fewer than its kind's curve needs, naming splits.training; empty otherwise.
[[nodiscard]] inline std::string small_split_warning(std::string_view kind, int training_tracks,
                                                     const std::string& regime) {
  const std::optional<int> needed = curve_flattens_at(kind);
  if (!needed || training_tracks >= *needed) return "";
  return std::string(kind) +
         ": the learned part switched off on splits.training = " + std::to_string(training_tracks) +
         " tracks of regime " + regime + ", fewer than the " + std::to_string(*needed) +
         " at which this kind's learning curve flattens (docs/methods.md): it may have been "
         "starved of data; raise splits.training and train again";
}

}  // namespace imm::trainer
