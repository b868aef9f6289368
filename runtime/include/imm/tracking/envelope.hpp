// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// A model that knows its envelope: a tracker watches whether the plots it receives still fit the
/// model. Over the last `window` updates, the sum of the normalized innovations squared
/// (NIS = νᵀ S⁻¹ ν, m = 2 per plot) of a consistent filter is χ² with m·window degrees of
/// freedom; outside its two-sided bounds at `significance` the plots no longer look like the
/// regime the model was trained for (above: larger innovations than the model expects — stronger
/// manoeuvres, more noise; below: smaller). `outside_envelope` is the signal an application needs
/// to fall back to another filter or to ask for a retraining.
///
/// The window and the significance are stored in every model file (`/envelope`, written by the
/// trainer with the defaults below; a file without it gets the defaults). The monitor keeps a
/// fixed ring of at most kMaxWindow values: no allocation per step, and add() never throws.

#include <array>

#include "imm/runtime_export.hpp"

namespace imm {

/// The envelope test's settings.
struct IMM_RUNTIME_EXPORT EnvelopeSettings {
  /// The longest window a monitor holds.
  static constexpr int kMaxWindow = 500;
  /// Updates per window (1 … kMaxWindow).
  int window = 20;
  /// The smallest significance: the bounds' χ² quantiles at significance / 2 are computable.
  static constexpr double kMinSignificance = 1e-10;
  /// The smallest calibrated dof (a smaller one makes the quantiles slow and meaningless).
  static constexpr double kMinDof = 0.01;
  /// The largest calibrated dof.
  static constexpr double kMaxDof = 1e6;
  /// The test's two-sided false-alarm probability for one full window (kMinSignificance ≤
  /// significance < 1).
  double significance = 0.01;
  /// The NIS sum of a full window is taken as scale · χ²(dof); dof 0 means m · window, the
  /// distribution of a consistent filter. An IMM on manoeuvring targets is not exactly consistent,
  /// so the trainer calibrates both on tracks of the model's regime (moment matching: the window
  /// sums' mean and variance), and the false-alarm rate is then the significance on that regime.
  double scale = 1.0;
  double dof = 0.0;  ///< (see scale); 0, or in [kMinDof, kMaxDof]
  /// Throws InvalidParameter naming "envelope.window", "envelope.significance", "envelope.scale" or
  /// "envelope.dof".
  void validate() const;
};

/// The running NIS test of EnvelopeSettings.
class IMM_RUNTIME_EXPORT EnvelopeMonitor {
 public:
  /// A monitor for plots of `measurement_dimension` (2); validates `settings`.
  explicit EnvelopeMonitor(const EnvelopeSettings& settings = {}, int measurement_dimension = 2);

  /// Adds one update's NIS (a non-finite or negative value is ignored); returns outside().
  bool add(double nis) noexcept;
  /// Whether the window is full and its NIS sum lies outside [lower_sum(), upper_sum()].
  [[nodiscard]] bool outside() const noexcept { return outside_; }
  /// The mean NIS over the values held (NaN before the first).
  [[nodiscard]] double mean() const noexcept;
  /// How many values the window holds (at most the window).
  [[nodiscard]] int filled() const noexcept { return filled_; }
  /// The χ² bounds of a full window's NIS sum.
  [[nodiscard]] double lower_sum() const noexcept { return lower_; }
  [[nodiscard]] double upper_sum() const noexcept { return upper_; }  ///< (see lower_sum)
  /// The settings it tests.
  [[nodiscard]] const EnvelopeSettings& settings() const noexcept { return settings_; }
  /// Empties the window (a new track).
  void reset() noexcept;

 private:
  EnvelopeSettings settings_;
  double lower_ = 0.0, upper_ = 0.0;
  std::array<double, EnvelopeSettings::kMaxWindow> ring_{};
  int head_ = 0, filled_ = 0, since_sum_ = 0;
  double sum_ = 0.0;
  bool outside_ = false;
};

}  // namespace imm
