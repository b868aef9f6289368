// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The covariance calibration of a model's trackers (imm/tracking/calibrated_filter.hpp), learned
/// on the training split of the regime recorded in the model file.
///
/// The model's filter runs over the split's tracks as a tracker runs it (two-point start, one plot
/// per scan) behind an identity calibration, which yields each plot's features (plots used since
/// the start, the NIS level) and its NIS, and, where truth exists, each estimate's position NEES.
/// The factors are moment matches, c = E[NIS | features] / 2 and c = E[NEES | features] / 2,
/// for a product of a start table and a level table, fitted by alternating the two (each given the
/// other) a few times. The level's bins are quantiles of the level over the split's plots.

#include <filesystem>
#include <string>

#include "imm/tracking/calibrated_filter.hpp"

namespace imm::trainer {

/// How the calibration is fitted.
struct CalibrationSettings {
  int tracks = 300;        ///< training tracks run (a recorded regime: at most its split's)
  int start_entries = 12;  ///< plots since the start with their own factor (the last holds on)
  int level_bins = 6;      ///< bins of the NIS level (quantiles)
  double memory = 0.7;     ///< λ of the level
  double nis_cap = 50.0;   ///< the most one plot adds to the level
  int min_samples = 200;   ///< fewer plots (or truths) in a cell than this: its factor stays 1

  /// Throws InvalidParameter naming the field (`tracks` 0 to 10⁶, 0 fitting nothing; the tables'
  /// sizes 1 to CovarianceCalibration::kMaxEntries; `memory` and `nis_cap` as a calibration's;
  /// `min_samples` ≥ 1).
  void validate() const;
};

/// What fit_calibration found.
struct CalibrationFit {
  CovarianceCalibration calibration;
  int tracks = 0;       ///< tracks run
  long plots = 0;       ///< NIS samples
  long truths = 0;      ///< NEES samples (0: no truth, the state factors stay 1)
  bool fitted = false;  ///< false: no regime recorded in the file, or too few plots
  double nis_before = 0.0, nis_after = 0.0;    ///< mean NIS over the samples, raw and calibrated
  double nees_before = 0.0, nees_after = 0.0;  ///< likewise the position NEES
};

/// Fits the calibration of `model_file` on its regime's training split. Throws InvalidParameter
/// for invalid settings (before reading anything) and io::FileError naming the file when it does
/// not read.
[[nodiscard]] CalibrationFit fit_calibration(const std::filesystem::path& model_file,
                                             const CalibrationSettings& settings = {});

/// Rewrites `model_file` (atomically, sealed) with `calibration` as its `/calibration`; everything
/// else is copied unchanged.
void store_calibration(const std::filesystem::path& model_file,
                       const CovarianceCalibration& calibration);

/// One line for the log: what was fitted, on what.
[[nodiscard]] std::string describe(const CalibrationFit& fit);

}  // namespace imm::trainer
