// SPDX-License-Identifier: Apache-2.0
#include "imm/filters/plain_imm.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <array>
#include <cmath>
#include <memory>

#include "estimation/cv_position_mode.hpp"
#include "filters/mode_field.hpp"
#include "imm/core/checks.hpp"
#include "imm/core/enum_names.hpp"
#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/estimation/kalman_mode.hpp"
#include "imm/estimation/scheduled_noise_mode.hpp"
#include "imm/estimation/turn_mode.hpp"
#include "imm/models/measurement/polar_measurement.hpp"
#include "imm/models/measurement/position_measurement.hpp"
#include "imm/models/motion/constant_acceleration.hpp"
#include "imm/models/motion/constant_velocity.hpp"
#include "imm/models/motion/coordinated_turn.hpp"
#include "imm/models/motion/singer.hpp"

namespace imm {
namespace {

constexpr std::array kMotionKindNames{EnumName<MotionKind>{MotionKind::kConstantVelocity, "cv"},
                                      EnumName<MotionKind>{MotionKind::kConstantAcceleration, "ca"},
                                      EnumName<MotionKind>{MotionKind::kSinger, "singer"},
                                      EnumName<MotionKind>{MotionKind::kCoordinatedTurn, "ct"}};
constexpr std::array kNoiseFormNames{
    EnumName<NoiseForm>{NoiseForm::kPiecewiseConstant, "piecewise"},
    EnumName<NoiseForm>{NoiseForm::kContinuous, "continuous"}};
constexpr std::array kMeasurementKindNames{
    EnumName<MeasurementKind>{MeasurementKind::kCartesian, "cartesian"},
    EnumName<MeasurementKind>{MeasurementKind::kPolar, "polar"}};
constexpr std::array kInitializationMethodNames{
    EnumName<InitializationMethod>{InitializationMethod::kExplicit, "explicit"},
    EnumName<InitializationMethod>{InitializationMethod::kTwoPoint, "two_point"}};

// The mixing-space indices of a mode of dimension N — CV [x, vx, y, vy], CA [x, vx, ax, y, vy,
// ay], CT [x, vx, y, vy, ω] — in the NX-state space: [x, vx, y, vy] (4), [x, vx, y, vy, ω] (5),
// [x, vx, ax, y, vy, ay] (6) or [x, vx, ax, y, vy, ay, ω] (7).
template <int N, int NX>
StateEmbedding<N, NX> embedding_for() {
  if constexpr (N == NX) {
    return StateEmbedding<N, NX>();
  } else if constexpr (N == 4 && NX == 5) {
    return StateEmbedding<N, NX>(std::array<int, 4>{0, 1, 2, 3});
  } else if constexpr (N == 4) {
    static_assert(NX == 6 || NX == 7);
    return StateEmbedding<N, NX>(std::array<int, 4>{0, 1, 3, 4});
  } else if constexpr (N == 6) {
    static_assert(NX == 7);
    return StateEmbedding<N, NX>(std::array<int, 6>{0, 1, 2, 3, 4, 5});
  } else {
    static_assert(N == kCoordinatedTurnDim && NX == 7, "no such embedding");
    return StateEmbedding<N, NX>(std::array<int, 5>{0, 1, 3, 4, 6});
  }
}

// The parameters of a mode's motion besides the interval (MotionParameters).
MotionParameters motion_parameters(const ModeSpec& mode) {
  return {mode.process_noise, mode.noise_form, mode.singer_tau, mode.singer_sigma, mode.turn_noise};
}

// Each motion over any interval Δt, from the same functions the spec's period is made with (so
// that Δt = T gives the same bits).
LinearMotionModel<4> cv_over(double dt, const MotionParameters& p) {
  return constant_velocity<2>(dt, p.process_noise, p.form);
}
LinearMotionModel<6> ca_over(double dt, const MotionParameters& p) {
  return constant_acceleration<2>(dt, p.process_noise, p.form);
}
LinearMotionModel<6> singer_over(double dt, const MotionParameters& p) {
  return singer<2>(dt, p.tau, p.sigma);
}
TurnMotionStep turn_over(double dt, const MotionParameters& p) {
  return {dt, coordinated_turn_noise(dt, p.process_noise, p.turn_noise, p.form)};
}

// The maker of a mode's linear motion over any interval (N = 4: CV; N = 6: CA or Singer).
template <int N>
MotionMaker<LinearMotionModel<N>> linear_maker(const ModeSpec& mode) {
  if constexpr (N == 4) {
    return {&cv_over, motion_parameters(mode)};
  } else {
    return {mode.motion == MotionKind::kSinger ? &singer_over : &ca_over, motion_parameters(mode)};
  }
}

// The coordinated-turn mode of a spec's mode (with its noise schedule, if any), with the spec's
// measurement.
template <int NX>
std::unique_ptr<ImmMode<NX, 2>> make_turn_mode(const ModeSpec& mode, double T,
                                               const MeasurementSpec& measurement) {
  constexpr int N = kCoordinatedTurnDim;
  const auto embedding = embedding_for<N, NX>();
  const MotionMaker<TurnMotionStep> maker{&turn_over, motion_parameters(mode)};
  const TurnMotionStep motion = maker(T);
  if (measurement.kind == MeasurementKind::kCartesian) {
    using Model = PositionMeasurement<N, 2>;
    return std::make_unique<CoordinatedTurnMode<NX, Model>>(mode.name, motion, mode.noise_schedule,
                                                            Model({0, 2}, measurement.covariance),
                                                            embedding, 1, maker);
  }
  using Model = PolarMeasurement<N>;
  return std::make_unique<CoordinatedTurnMode<NX, Model>>(mode.name, motion, mode.noise_schedule,
                                                          Model(0, 2, measurement.covariance),
                                                          embedding, 1, maker);
}

template <int NX, int N>
std::unique_ptr<ImmMode<NX, 2>> make_mode(const ModeSpec& mode, const LinearMotionModel<N>& motion,
                                          const MeasurementSpec& measurement) {
  constexpr int kY = N / 2;  // index of y: 2 in [x, vx, y, vy], 3 in [x, vx, ax, y, vy, ay]
  const auto embedding = embedding_for<N, NX>();
  if (mode.noise_schedule) {
    const LinearMotionStep<N> step{motion};
    if (measurement.kind == MeasurementKind::kCartesian) {
      using Model = PositionMeasurement<N, 2>;
      return std::make_unique<ScheduledNoiseMode<NX, LinearMotionStep<N>, Model>>(
          mode.name, step, *mode.noise_schedule, Model({0, kY}, measurement.covariance), embedding);
    }
    using Model = PolarMeasurement<N>;
    return std::make_unique<ScheduledNoiseMode<NX, LinearMotionStep<N>, Model>>(
        mode.name, step, *mode.noise_schedule, Model(0, kY, measurement.covariance), embedding);
  }
  if constexpr (NX == 4 && N == 4) {
    if (measurement.kind == MeasurementKind::kCartesian) {
      // The written-out algebra of the common case (cv_position_mode.hpp).
      return std::make_unique<CvPositionMode>(mode.name, motion.transition(0, 1),
                                              motion.process_noise, measurement.covariance,
                                              linear_maker<N>(mode));
    }
  }
  if (measurement.kind == MeasurementKind::kCartesian) {
    using Model = PositionMeasurement<N, 2>;
    return std::make_unique<KalmanMode<NX, N, Model>>(mode.name, motion,
                                                      Model({0, kY}, measurement.covariance),
                                                      embedding, 1, linear_maker<N>(mode));
  }
  using Model = PolarMeasurement<N>;
  return std::make_unique<KalmanMode<NX, N, Model>>(
      mode.name, motion, Model(0, kY, measurement.covariance), embedding, 1, linear_maker<N>(mode));
}

}  // namespace

std::string_view to_string(MotionKind kind) { return name_of(kMotionKindNames, kind); }

std::string_view to_string(NoiseForm form) { return name_of(kNoiseFormNames, form); }

std::string_view to_string(MeasurementKind kind) { return name_of(kMeasurementKindNames, kind); }

std::string_view to_string(InitializationMethod method) {
  return name_of(kInitializationMethodNames, method);
}

MotionKind motion_kind_from(std::string_view name, const std::string& field) {
  return value_named(kMotionKindNames, name, field, "motion model");
}

NoiseForm noise_form_from(std::string_view name, const std::string& field) {
  return value_named(kNoiseFormNames, name, field, "noise form");
}

MeasurementKind measurement_kind_from(std::string_view name, const std::string& field) {
  return value_named(kMeasurementKindNames, name, field, "measurement");
}

InitializationMethod initialization_method_from(std::string_view name, const std::string& field) {
  return value_named(kInitializationMethodNames, name, field, "initialization");
}

bool PlainImmSpec::has_noise_schedule() const {
  return std::any_of(modes.begin(), modes.end(),
                     [](const ModeSpec& m) { return m.noise_schedule.has_value(); });
}

bool PlainImmSpec::has_turn_rate() const {
  return std::any_of(modes.begin(), modes.end(),
                     [](const ModeSpec& m) { return m.motion == MotionKind::kCoordinatedTurn; });
}

int PlainImmSpec::mixing_dimension() const {
  const bool accelerations = std::any_of(modes.begin(), modes.end(), [](const ModeSpec& m) {
    return m.motion == MotionKind::kConstantAcceleration || m.motion == MotionKind::kSinger;
  });
  return (accelerations ? 6 : 4) + (has_turn_rate() ? 1 : 0);
}

void PlainImmSpec::validate() const {
  limits::require_sample_period(sample_period, "sample_period");
  require(!modes.empty() && static_cast<int>(modes.size()) <= kMaxModes, "modes",
          "need 1 to " + std::to_string(kMaxModes) + " modes");
  for (std::size_t i = 0; i < modes.size(); ++i) {
    const ModeSpec& mode = modes[i];
    require(!mode.name.empty(), detail::mode_field(i, "name"), "must not be empty");
    for (std::size_t j = 0; j < i; ++j) {
      require(modes[j].name != mode.name, detail::mode_field(i, "name"),
              std::string("'").append(printable(mode.name)).append("' is repeated"));
    }
    require(!mode.noise_schedule || mode.motion != MotionKind::kSinger,
            detail::mode_field(i, "noise_schedule"),
            "a Singer mode's noise is set by τ and σ_a, not scheduled");
    if (mode.motion == MotionKind::kSinger) {
      limits::require_in(mode.singer_tau, limits::kTimeConstant, detail::mode_field(i, "tau"));
      limits::require_in(mode.singer_sigma, limits::kAcceleration,
                         detail::mode_field(i, "sigma_a"));
    } else {
      limits::require_in(mode.process_noise, limits::kVariance,
                         detail::mode_field(i, "process_noise"));
    }
    if (mode.motion == MotionKind::kCoordinatedTurn) {
      limits::require_in(mode.turn_noise, limits::kTurnRateNoise,
                         detail::mode_field(i, "turn_noise"));
    }
  }
  const auto n = static_cast<Eigen::Index>(modes.size());
  validate_mode_probabilities(transition, initial_probabilities, static_cast<int>(n));
  const Eigen::Matrix2d& R = measurement.covariance;
  require(R.allFinite() && R.cwiseAbs().maxCoeff() <= limits::kVariance.max &&
              R.isApprox(R.transpose(), 1e-12) &&
              Eigen::LLT<Eigen::Matrix2d>(R).info() == Eigen::Success,
          "measurement.covariance", "must be finite, symmetric and positive definite");
  if (initialization.method == InitializationMethod::kExplicit) {
    const int nx = mixing_dimension();
    require(initialization.state.size() == nx && initialization.state.allFinite(),
            "initialization.state", "must hold " + std::to_string(nx) + " finite values");
    const Eigen::MatrixXd& P = initialization.covariance;
    require(P.rows() == nx && P.cols() == nx && P.allFinite() && P.isApprox(P.transpose(), 1e-12) &&
                Eigen::LLT<Eigen::MatrixXd>(P).info() == Eigen::Success,
            "initialization.covariance",
            "must be a finite, symmetric, positive definite " + std::to_string(nx) + "x" +
                std::to_string(nx) + " matrix");
  } else {
    limits::require_in(initialization.acceleration_variance, limits::kVariance,
                       "initialization.acceleration_variance");
    limits::require_in(initialization.turn_rate_variance, limits::kTurnRateVariance,
                       "initialization.turn_rate_variance");
    // A turn rate that starts certain at 0 is learned only through Q: a CT mode needs its prior.
    require(!has_turn_rate() || initialization.turn_rate_variance > 0.0,
            "initialization.turn_rate_variance",
            "must be positive with a coordinated-turn mode (the prior variance of ω, rad²/s²)");
  }
}

template <int NX>
std::vector<std::unique_ptr<ImmMode<NX, 2>>> build_plain_imm_modes(const PlainImmSpec& spec) {
  spec.validate();
  if (spec.mixing_dimension() != NX) {
    throw InvalidParameter("modes", "spec needs a " + std::to_string(spec.mixing_dimension()) +
                                        "-state mixing space, not " + std::to_string(NX));
  }
  const double T = spec.sample_period;
  std::vector<std::unique_ptr<ImmMode<NX, 2>>> modes;
  for (const ModeSpec& mode : spec.modes) {
    if (mode.motion == MotionKind::kConstantVelocity) {
      modes.push_back(make_mode<NX, 4>(mode, linear_maker<4>(mode)(T), spec.measurement));
    } else if (mode.motion == MotionKind::kCoordinatedTurn) {
      if constexpr (NX == 5 || NX == 7)
        modes.push_back(make_turn_mode<NX>(mode, T, spec.measurement));
    } else if constexpr (NX >= 6) {  // CA and Singer need the 6- or 7-state space (checked above)
      modes.push_back(make_mode<NX, 6>(mode, linear_maker<6>(mode)(T), spec.measurement));
    }
  }
  return modes;
}

template <int NX>
ImmEstimator<NX, 2> build_plain_imm(const PlainImmSpec& spec) {
  return ImmEstimator<NX, 2>(build_plain_imm_modes<NX>(spec), spec.transition,
                             spec.initial_probabilities);
}

template std::vector<std::unique_ptr<ImmMode<4, 2>>> build_plain_imm_modes<4>(const PlainImmSpec&);
template std::vector<std::unique_ptr<ImmMode<6, 2>>> build_plain_imm_modes<6>(const PlainImmSpec&);
template std::vector<std::unique_ptr<ImmMode<5, 2>>> build_plain_imm_modes<5>(const PlainImmSpec&);
template std::vector<std::unique_ptr<ImmMode<7, 2>>> build_plain_imm_modes<7>(const PlainImmSpec&);
template ImmEstimator<4, 2> build_plain_imm<4>(const PlainImmSpec&);
template ImmEstimator<6, 2> build_plain_imm<6>(const PlainImmSpec&);
template ImmEstimator<5, 2> build_plain_imm<5>(const PlainImmSpec&);
template ImmEstimator<7, 2> build_plain_imm<7>(const PlainImmSpec&);

PlainImm build_plain_imm(const PlainImmSpec& spec) {
  spec.validate();
  switch (spec.mixing_dimension()) {
    case 4:
      return PlainImm(std::in_place_index<0>, build_plain_imm<4>(spec));
    case 6:
      return PlainImm(std::in_place_index<1>, build_plain_imm<6>(spec));
    case 5:
      return PlainImm(std::in_place_index<2>, build_plain_imm<5>(spec));
    default:
      return PlainImm(std::in_place_index<3>, build_plain_imm<7>(spec));
  }
}

}  // namespace imm
