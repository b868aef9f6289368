// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The multi-target experiment: scenes of several targets of a regime at once, each detected with
/// a probability, among Poisson clutter uniform over the scene's region; every model given tracks
/// them with the reference GNN tracker (gnn_tracker.hpp) on the same scenes and is judged by GOSPA
/// (gospa.hpp) against the truth, with the paired-bootstrap interval of its difference to the
/// first model's, and by its tracks' continuity (breaks and swaps). A scene's targets are test
/// tracks of the regime (independent draws from
/// --seed), its detections and clutter drawn from the same seed.
///
/// `imm-eval multi-target --models A.h5 B.h5 … [--regime R] [--targets 3] [--pd 0.9[,0.7…]]
/// [--clutter 10[,30…]] [--runs 20]` runs every detection probability with every clutter density
/// on the same scenes' targets, prints a table per condition and writes metrics.json (its
/// "conditions", each with its models' figures).

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "imm/datasets/regime.hpp"
#include "imm/evaluation/experiment.hpp"
#include "imm/evaluation/gnn_tracker.hpp"
#include "imm/evaluation/uncertainty.hpp"

namespace imm::evaluation {

/// What the scenes hold and how they are judged.
struct MultiTargetSettings {
  int targets = 3;                     ///< targets per scene
  double detection_probability = 0.9;  ///< Pd of every target at every scan
  double clutter_per_scan = 10.0;      ///< mean false plots per scan over the scene's region
  int runs = 20;                       ///< scenes (2 to 10⁶)
  std::uint64_t seed = 1;              ///< the scenes' seed
  int warm_up = 5;                     ///< first scans not scored (tracks start in pairs)
  /// GOSPA's cut-off (length); 0: 10 × the regime's plot σ (Regime::position_sigma).
  double cutoff = 0.0;
  /// The tracker's settings; max_speed 0: 1.5 × the regime's largest start speed.
  GnnSettings gnn;
  /// Throws InvalidParameter naming the field.
  void validate() const;
};

/// One model's figures over the scenes (GOSPA per scored scan, averaged over scans and scenes).
struct MultiTargetFigures {
  std::string model;            ///< its file
  double gospa = 0.0;           ///< mean GOSPA
  double localization = 0.0;    ///< mean of its localization part (p-th power)
  double missed = 0.0;          ///< mean of the missed part (p-th power)
  double false_tracks = 0.0;    ///< mean of the false part (p-th power)
  double tracks_started = 0.0;  ///< per scene
  /// Per scene: scored scans at which another track than before follows a target — one that
  /// followed another target (a swap) or a new one (a break, after a lost or duplicated track).
  double breaks = 0.0, swaps = 0.0;
  Eigen::VectorXd per_run;  ///< each scene's mean GOSPA
  Difference versus_first;  ///< GOSPA − the first model's, paired over the scenes
  /// Why the model was not run (its filter cannot gate on its prediction); empty when it ran.
  std::string refused;
};

/// The experiment's result, one entry per model in the order given.
struct MultiTargetResult {
  double cutoff = 0.0;
  std::vector<MultiTargetFigures> models;
};

/// Runs the scenes. Throws InvalidParameter naming the field, or io::FileError for a model file
/// that does not load. A model whose filter does not split its cycle (a wIMM that fuses the
/// azimuth) is listed with the reason and not run; the first model must run.
[[nodiscard]] MultiTargetResult run_multi_target(const datasets::Regime& regime,
                                                 const std::vector<std::filesystem::path>& models,
                                                 MultiTargetSettings settings);

}  // namespace imm::evaluation
