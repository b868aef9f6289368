// SPDX-License-Identifier: Apache-2.0
#include "imm/tracking/plain_imm_track_bank.hpp"

#include <limits>
#include <string>

#include "bank_checks.hpp"
#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/tracking/track_filter.hpp"
#include "initial_state_check.hpp"

namespace imm {

template <int NX>
PlainImmTrackBank<NX>::PlainImmTrackBank(const PlainImmSpec& spec, std::size_t capacity)
    : TrackBankCalls("PlainImmTrackBank") {
  hold_tracks(capacity);
  spec.validate();
  if (spec.mixing_dimension() != NX) {
    throw InvalidParameter("modes", "their mixing space has " +
                                        std::to_string(spec.mixing_dimension()) +
                                        " states, not the bank's " + std::to_string(NX));
  }
  sample_period_ = spec.sample_period;
  tracks_.reserve(capacity);
  for (std::size_t t = 0; t < capacity; ++t) tracks_.push_back(build_plain_imm<NX>(spec));
}

template <int NX>
void PlainImmTrackBank<NX>::initialize(std::size_t track, const GaussianState<NX>& state) {
  const auto t = static_cast<std::size_t>(checked(track));
  detail::check_initial_state(state);
  tracks_[t].initialize(state);
  mark_initialized(checked(track));
}

template <int NX>
void PlainImmTrackBank<NX>::step_lanes(const LaneStep& call) {
  for (std::size_t t = 0; t < call.plots.size(); ++t) {
    call.status[t] = tracks_[t].step(call.plots[t]);
    if (call.nis == nullptr) continue;
    call.nis[t] = std::numeric_limits<double>::quiet_NaN();
    Vector<2> nu;
    SquareMatrix<2> S;
    if (call.status[t] != StepStatus::kOk || !tracks_[t].innovation(nu, S)) continue;
    // As last_step_nis of the one-track filter.
    call.nis[t] = normalized_innovation_squared(nu, S).value_or(call.nis[t]);
  }
}

template <int NX>
void PlainImmTrackBank<NX>::score_lanes(const LaneScore& call) {
  const auto tracks = static_cast<std::size_t>(call.out.rows());
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  for (std::size_t t = 0; t < tracks; ++t) {
    ImmEstimator<NX, 2>& track = tracks_[t];
    const bool predicted = track.predict() == StepStatus::kOk;
    const double track_gate = call.gate_of(t);
    for (std::size_t q = 0; q < call.plots.size(); ++q) {
      double& entry = call.out(static_cast<Eigen::Index>(t), static_cast<Eigen::Index>(q));
      if (!predicted || !limits::usable_measurement(call.plots[q])) {
        entry = kNaN;
      } else if (track.candidate_distance(call.plots[q]) > track_gate) {
        entry = -std::numeric_limits<double>::infinity();
      } else {
        entry = track.candidate_log_likelihood(call.plots[q]);
      }
    }
  }
}

template <int NX>
bool PlainImmTrackBank<NX>::set_interval(double interval) {
  const double periods = interval / sample_period_;
  // Every track has the same modes: the first refuses what every one would, before any changes.
  for (ImmEstimator<NX, 2>& track : tracks_) {
    if (!track.set_interval(interval, periods)) return false;
  }
  return true;
}

template <int NX>
GaussianState<NX> PlainImmTrackBank<NX>::estimate(std::size_t track) const {
  return tracks_[static_cast<std::size_t>(checked(track))].estimate();
}

template <int NX>
ModeVector PlainImmTrackBank<NX>::mode_probabilities(std::size_t track) const {
  return tracks_[static_cast<std::size_t>(checked(track))].mode_probabilities();
}

template <int NX>
ModeVector PlainImmTrackBank<NX>::log_mode_probabilities(std::size_t track) const {
  return tracks_[static_cast<std::size_t>(checked(track))].log_mode_probabilities();
}

template class PlainImmTrackBank<4>;
template class PlainImmTrackBank<5>;
template class PlainImmTrackBank<6>;
template class PlainImmTrackBank<7>;

}  // namespace imm
