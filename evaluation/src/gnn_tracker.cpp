// SPDX-License-Identifier: Apache-2.0
#include "imm/evaluation/gnn_tracker.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/evaluation/assignment.hpp"
#include "imm/models/measurement/polar_measurement.hpp"

namespace imm::evaluation {

void GnnSettings::validate() const {
  if (!(gate > 0.0) || !std::isfinite(gate)) throw InvalidParameter("gate", "must be > 0");
  if (confirm_hits < 2) throw InvalidParameter("confirm_hits", "must be ≥ 2 (the start's plots)");
  if (confirm_scans < confirm_hits) {
    throw InvalidParameter("confirm_scans", "must be ≥ confirm_hits");
  }
  if (misses_to_delete < 1) throw InvalidParameter("misses_to_delete", "must be ≥ 1");
  if (!(max_speed > 0.0) || !std::isfinite(max_speed)) {
    throw InvalidParameter("max_speed", "must be > 0");
  }
  if (!(clutter_density >= 0.0) || !std::isfinite(clutter_density)) {
    throw InvalidParameter("clutter_density", "must be ≥ 0 and finite");
  }
  if (!(detection_probability > 0.0 && detection_probability <= 1.0)) {
    throw InvalidParameter("detection_probability", "must be in (0, 1]");
  }
  if (!(false_track_rate > 0.0 && false_track_rate < 0.5)) {
    throw InvalidParameter("false_track_rate", "must be in (0, 0.5)");
  }
  if (!(true_track_loss > 0.0 && true_track_loss < 0.5)) {
    throw InvalidParameter("true_track_loss", "must be in (0, 0.5)");
  }
}

GnnTracker::GnnTracker(FilterMaker maker, GnnSettings settings)
    : maker_(std::move(maker)), settings_(settings) {
  settings_.validate();
  if (!maker_.make || !maker_.make()->has_split_cycle()) {
    throw InvalidParameter("model",
                           "its filter does not split its cycle (a wIMM's update fuses the "
                           "plot with the prediction): the tracker gates on the prediction");
  }
}

Eigen::Vector2d GnnTracker::position_of(const Eigen::Vector2d& z) const {
  if (maker_.options.measurement_kind == MeasurementKind::kCartesian) return z;
  return polar_to_cartesian(z, maker_.options.measurement_covariance).position;
}

void GnnTracker::process(std::int64_t scan, std::span<const Eigen::Vector2d> plots) {
  if (started_ && scan <= last_scan_) {
    throw std::invalid_argument("GnnTracker::process: scan " + std::to_string(scan) +
                                " after scan " + std::to_string(last_scan_));
  }
  // Scans skipped since the last: every track misses them.
  for (std::int64_t k = last_scan_ + 1; started_ && k < scan; ++k) {
    for (Track& track : tracks_) {
      if (track.filter->predict() == StepStatus::kOk) (void)track.filter->miss();
      ++track.misses;
      ++track.age;
    }
  }
  started_ = true;
  last_scan_ = scan;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const auto n = static_cast<Eigen::Index>(tracks_.size());
  const auto m = static_cast<Eigen::Index>(plots.size());
  std::vector<char> predicted(tracks_.size());
  Eigen::MatrixXd cost = Eigen::MatrixXd::Constant(n, m, kInf);
  for (Eigen::Index t = 0; t < n; ++t) {
    Track& track = tracks_[static_cast<std::size_t>(t)];
    predicted[static_cast<std::size_t>(t)] = track.filter->predict() == StepStatus::kOk ? 1 : 0;
    if (!predicted[static_cast<std::size_t>(t)]) continue;
    for (Eigen::Index q = 0; q < m; ++q) {
      const Eigen::Vector2d& z = plots[static_cast<std::size_t>(q)];
      if (!limits::usable_measurement(z)) continue;
      const double d2 = track.filter->candidate_distance(z);
      if (d2 <= settings_.gate) cost(t, q) = d2;
    }
  }
  const std::vector<int> chosen = gated_assignment(cost, 0.5 * settings_.gate);
  // The sequential test's terms (with a clutter density): per plot log(Pd) − log β, per miss
  // log(1 − Pd·P_G) with P_G = 1 − e^(−gate/2), the χ²(2) gate's probability.
  const bool ratio = settings_.clutter_density > 0.0;
  const double pd = settings_.detection_probability;
  const double log_detection = std::log(pd);
  const double log_clutter = ratio ? std::log(settings_.clutter_density) : 0.0;
  const double log_miss = std::log1p(-pd * -std::expm1(-0.5 * settings_.gate));
  const double confirm_above =
      std::log((1.0 - settings_.true_track_loss) / settings_.false_track_rate);
  const double delete_below =
      std::log(settings_.true_track_loss / (1.0 - settings_.false_track_rate));
  std::vector<char> used(plots.size(), 0);
  for (Eigen::Index t = 0; t < n; ++t) {
    Track& track = tracks_[static_cast<std::size_t>(t)];
    const int q = chosen[static_cast<std::size_t>(t)];
    bool hit = false;
    double log_likelihood = 0.0;
    if (predicted[static_cast<std::size_t>(t)]) {
      const Eigen::Vector2d* z = q >= 0 ? &plots[static_cast<std::size_t>(q)] : nullptr;
      if (z != nullptr && ratio && !track.confirmed) {
        log_likelihood = track.filter->candidate_log_likelihood(*z);
      }
      if (z != nullptr && track.filter->update(*z) == StepStatus::kOk) {
        hit = true;
        used[static_cast<std::size_t>(q)] = 1;
      } else {
        (void)track.filter->miss();
      }
    }
    ++track.age;
    track.hits += hit ? 1 : 0;
    track.misses = hit ? 0 : track.misses + 1;
    if (ratio && !track.confirmed) {
      track.score += hit && std::isfinite(log_likelihood)
                         ? log_detection + log_likelihood - log_clutter
                         : log_miss;
      track.confirmed = track.score >= confirm_above;
    } else if (!track.confirmed && track.hits >= settings_.confirm_hits &&
               track.age <= settings_.confirm_scans) {
      track.confirmed = true;
    }
  }
  // Deletion: a tentative track that can no longer reach M of N (or whose ratio fell below its
  // threshold), a confirmed one after its misses.
  std::erase_if(tracks_, [&](const Track& track) {
    if (track.confirmed) return track.misses >= settings_.misses_to_delete;
    if (ratio) return track.score <= delete_below;
    const int left = settings_.confirm_scans - track.age;
    return track.hits + std::max(left, 0) < settings_.confirm_hits;
  });
  start_tracks(scan, plots, used);
}

void GnnTracker::start_tracks(std::int64_t scan, std::span<const Eigen::Vector2d> plots,
                              const std::vector<char>& used) {
  std::vector<Seed> next;
  std::vector<char> seed_used(seeds_.size(), 0);
  for (std::size_t q = 0; q < plots.size(); ++q) {
    if (used[q] || !limits::usable_measurement(plots[q])) continue;
    const Eigen::Vector2d position = position_of(plots[q]);
    if (!position.allFinite()) continue;
    // The nearest unused seed within reach.
    int best = -1;
    double best_distance = std::numeric_limits<double>::infinity();
    for (std::size_t s = 0; s < seeds_.size(); ++s) {
      if (seed_used[s]) continue;
      const double reach = settings_.max_speed * maker_.options.sample_period *
                           static_cast<double>(scan - seeds_[s].scan);
      const double distance = (position - seeds_[s].position).norm();
      if (distance <= reach && distance < best_distance) {
        best = static_cast<int>(s);
        best_distance = distance;
      }
    }
    if (best < 0) {
      next.push_back({scan, plots[q], position});
      continue;
    }
    const Seed& seed = seeds_[static_cast<std::size_t>(best)];
    Track track;
    track.filter = maker_.make();
    const std::optional<TrackStart> start = two_point_start(
        maker_.options, track.filter->state_dimension(), seed.scan, seed.z, scan, plots[q]);
    if (!start) {
      next.push_back({scan, plots[q], position});
      continue;
    }
    seed_used[static_cast<std::size_t>(best)] = 1;
    track.filter->initialize(start->mean, start->covariance);
    track.id = next_id_++;
    track.hits = 2;
    track.age = 2;
    // With a clutter density the two starting plots carry no evidence yet (the start is fitted to
    // them); the ratio starts at 0.
    track.confirmed = settings_.clutter_density == 0.0 && track.hits >= settings_.confirm_hits;
    tracks_.push_back(std::move(track));
  }
  seeds_ = std::move(next);
}

std::vector<GnnEstimate> GnnTracker::estimates(bool tentative) const {
  std::vector<GnnEstimate> out;
  for (const Track& track : tracks_) {
    if (!track.confirmed && !tentative) continue;
    const int dimension = track.filter->state_dimension();
    GnnEstimate e;
    e.id = track.id;
    e.confirmed = track.confirmed;
    e.mean.resize(dimension);
    Eigen::VectorXd variance(dimension);
    e.covariance.resize(dimension, dimension);
    track.filter->state(e.mean, variance);
    track.filter->covariance(e.covariance);
    e.position << e.mean(0), e.mean(dimension / 2);
    out.push_back(std::move(e));
  }
  return out;
}

}  // namespace imm::evaluation
