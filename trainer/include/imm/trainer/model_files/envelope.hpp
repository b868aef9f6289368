// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The envelope test a model's trackers run (imm/tracking/envelope.hpp), calibrated on its own
/// regime. For a consistent filter the NIS sum of a window of W plots is χ²(2W); an IMM on
/// manoeuvring targets is not exactly consistent (measured on agile_air: the tuned IMM's windows
/// leave the 1 % χ² bounds 13 % of the time on the regime's own test tracks), so the bounds are
/// taken from scale · χ²(dof) with scale and dof matched to the mean and variance of the window
/// sums over fresh tracks of the regime (its validation stream, beyond the validation split's
/// tracks' count: never the test split).

#include <filesystem>
#include <string>

#include "imm/tracking/envelope.hpp"

namespace imm::trainer {

/// What calibrate_envelope measured.
struct EnvelopeCalibration {
  EnvelopeSettings settings;          ///< the window and significance kept, scale and dof fitted
  int tracks = 0;                     ///< tracks run
  int windows = 0;                    ///< disjoint full windows measured
  double mean = 0.0, variance = 0.0;  ///< of the window sums
  bool calibrated = false;  ///< false: no regime, or too few windows (the χ² defaults stay)
  bool recorded = false;    ///< the tracks were a recorded regime's validation windows
  /// Tracks drawn but not run: their plot noise is not the R the model's tracker assumes (a
  /// regime with one case per plot noise: the model is built for one of them).
  int other_noise = 0;
  /// No track of the regime has the model's R: all were run, and the fit includes the mismatch.
  bool noise_mismatch = false;
};

/// Runs the model's tracker over `tracks` tracks of the regime recorded in `model_file` and fits
/// scale and dof to its window sums. Only tracks whose plots have the noise covariance the tracker
/// assumes (its R) are run: the envelope measures the model on the plots it was built for, as an
/// evaluation does, and flags plots noisier than that. Throws io::FileError naming the file when
/// it does not read.
[[nodiscard]] EnvelopeCalibration calibrate_envelope(const std::filesystem::path& model_file,
                                                     int tracks = 200);

/// Rewrites `model_file` (atomically, sealed) with `settings` as its `/envelope`; everything else
/// is copied unchanged.
void store_envelope(const std::filesystem::path& model_file, const EnvelopeSettings& settings);

/// calibrate_envelope, then store_envelope when it calibrated; returns what it measured.
EnvelopeCalibration calibrate_and_store_envelope(const std::filesystem::path& model_file,
                                                 int tracks = 200);

/// One line for the log: what was calibrated, on what.
[[nodiscard]] std::string describe(const EnvelopeCalibration& calibration);

}  // namespace imm::trainer
