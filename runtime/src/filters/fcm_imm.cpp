// SPDX-License-Identifier: Apache-2.0
#include "imm/filters/fcm_imm.hpp"

#include <cmath>
#include <limits>

#include "imm/core/checks.hpp"
#include "imm/core/enum_names.hpp"
#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/models/motion/constant_velocity.hpp"

namespace imm {
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

lanes::AxisEstimate axis_estimate(const GaussianState<2>& s) {
  return {s.mean(0), s.mean(1), s.covariance(0, 0), s.covariance(0, 1), s.covariance(1, 1)};
}

GaussianState<2> gaussian_state(const lanes::AxisEstimate& e) {
  GaussianState<2> s;
  s.mean << e.x0, e.x1;
  s.covariance << e.p00, e.p01, e.p01, e.p11;
  return s;
}

std::string mode_name(double q) {
  char buffer[48];
  std::snprintf(buffer, sizeof buffer, "q=%.4g", q);
  return buffer;
}

}  // namespace

namespace {
constexpr std::array kMembershipScaleNames{
    EnumName<MembershipScale>{MembershipScale::kSeed, "seed"},
    EnumName<MembershipScale>{MembershipScale::kInnovation, "innovation"}};
}  // namespace

std::string_view to_string(MembershipScale scale) { return name_of(kMembershipScaleNames, scale); }

MembershipScale membership_scale_from(std::string_view name, const std::string& field) {
  return value_named(kMembershipScaleNames, name, field, "membership scale");
}

Eigen::MatrixXd FcmImmSpec::switching_transition(int n, double stay) {
  if (n == 1) return Eigen::MatrixXd::Ones(1, 1);
  Eigen::MatrixXd pi = Eigen::MatrixXd::Constant(n, n, (1.0 - stay) / (n - 1));
  pi.diagonal().setConstant(stay);
  return pi;
}

TrackOptions FcmImmSpec::track_options(std::int64_t max_gap) const {
  validate();
  return two_point_track_options(
      sample_period, MeasurementKind::kCartesian,
      measurement_sigma * measurement_sigma * Eigen::Matrix2d::Identity(), max_gap);
}

void FcmImmSpec::validate() const {
  limits::require_sample_period(sample_period, "sample_period");
  limits::require_in(measurement_sigma, limits::kSigma, "measurement_sigma");
  const int n = mode_count();
  if (n < 1 || n > 8) throw InvalidParameter("process_noise", "need 1 to 8 modes");
  for (int j = 0; j < n; ++j) {
    const double q = process_noise[static_cast<std::size_t>(j)];
    const std::string field = "process_noise[" + std::to_string(j) + "]";
    limits::require_in(q, limits::kVariance, field);
    if (j > 0 && q < process_noise[static_cast<std::size_t>(j - 1)]) {
      throw InvalidParameter(field, "noise levels must be ascending");
    }
  }
  if (transition.rows() != n || transition.cols() != n) {
    throw InvalidParameter("transition", "must be " + std::to_string(n) + "×" + std::to_string(n));
  }
  if (initial_probabilities.size() != n) {
    throw InvalidParameter("initial_probabilities", "must have " + std::to_string(n) + " entries");
  }
  validate_mode_probabilities(transition, initial_probabilities, n);
  validate_within("clustering.", clustering);
  if (window < 3 || window > SlidingFuzzyCMeans::kMaxWindow) {
    throw InvalidParameter(
        "window", "must be in [3, " + std::to_string(SlidingFuzzyCMeans::kMaxWindow) + "]");
  }
  limits::require_in(separation, limits::kFactor, "separation");
  if (!(compensation_gain >= 0.0 && compensation_gain <= 1.0)) {
    throw InvalidParameter("compensation_gain", "must be in [0, 1]");
  }
  if (mean_memberships.size() > 0 || constant_memberships) {
    if (mean_memberships.rows() != n || mean_memberships.cols() != kFcmClusters) {
      throw InvalidParameter("mean_memberships", "must be " + std::to_string(n) + "×3");
    }
    for (int j = 0; j < n; ++j) {
      const auto row = mean_memberships.row(j);
      if (!row.allFinite() || (row.array() < 0.0).any() || std::abs(row.sum() - 1.0) > 1e-9) {
        throw InvalidParameter("mean_memberships",
                               "row " + std::to_string(j) + " must be ≥ 0 and sum to 1");
      }
    }
  }
}

lanes::FcmModeConstants fcm_mode_constants(const FcmImmSpec& spec, int mode) {
  const double T = spec.sample_period;
  const SquareMatrix<2> Q = cv_axis_noise(T, spec.process_noise[static_cast<std::size_t>(mode)],
                                          NoiseForm::kPiecewiseConstant);
  lanes::FcmModeConstants c;
  c.T = T;
  c.R = spec.measurement_sigma * spec.measurement_sigma;
  c.q00 = Q(0, 0);
  c.q01 = Q(0, 1);
  c.q10 = Q(1, 0);
  c.q11 = Q(1, 1);
  c.gain = mode > 0 || spec.compensate_lowest ? spec.compensation_gain : 0.0;
  c.g_hat1 = 2.0 / T;
  c.innovation_scale = spec.scale == MembershipScale::kInnovation;
  return c;
}

FcmCompensatedMode::FcmCompensatedMode(const FcmImmSpec& spec, int mode)
    : name_(mode_name(spec.process_noise[static_cast<std::size_t>(mode)])),
      constants_(fcm_mode_constants(spec, mode)),
      F_(cv_axis_transition(spec.sample_period)),
      R_(SquareMatrix<1>::Constant(spec.measurement_sigma * spec.measurement_sigma)),
      constant_(spec.constant_memberships) {
  H_ << 1.0, 0.0;
  if (constant_) constant_memberships_ = spec.mean_memberships.row(mode).transpose();
  ClusterVector lower = ClusterVector::Constant(-kInfinity);
  ClusterVector upper = ClusterVector::Constant(kInfinity);
  if (constants_.innovation_scale) {
    upper(0) = -spec.separation;
    lower(1) = upper(1) = 0.0;
    lower(2) = spec.separation;
  }
  clustering_ = SlidingFuzzyCMeans(spec.window, spec.clustering, lower, upper);
}

void FcmCompensatedMode::reset(const GaussianState<2>& state) {
  estimate_ = state;
  clustering_.reset();
  memberships_ = ClusterVector(0.0, 1.0, 0.0);
  compensation_ = 0.0;
  error_ = 0.0;
}

ModeStep FcmCompensatedMode::propose(const GaussianState<2>& mixed, const Vector<1>& z) {
  if (!limits::usable_measurement(z)) return {StepStatus::kInvalidMeasurement, 0.0};
  // lanes::fcm_predict and fcm_update for a double, with the clustering between them.
  const lanes::FcmPrediction<double> p = lanes::fcm_predict(constants_, axis_estimate(mixed), z(0));
  pending_ = gaussian_state(p.predicted);
  if (!p.usable) return {StepStatus::kSingularInnovation, 0.0};
  pending_error_ = p.error;  // e(k), eq. (13)

  pending_clustered_ = !constant_;
  // The window holds errors in innovation standard deviations (kInnovation) or as they are
  // (kSeed; the memberships are scale-free there, so dividing would change nothing but the
  // centers' units).
  pending_memberships_ = constant_ ? constant_memberships_ : clustering_.propose(p.clustered);
  pending_compensation_ = lanes::fcm_compensation(constants_, pending_memberships_(1));

  // K_c = K + c (ĝ − K) (derivation, step 4), then the Joseph-form update with K_c.
  const lanes::FcmUpdate<double> u = lanes::fcm_update(constants_, p, pending_compensation_);
  keep_innovation(Vector<1>(p.error), SquareMatrix<1>(p.s));
  if (!u.factored) return {StepStatus::kSingularInnovation, 0.0};
  if (!u.finite) return {StepStatus::kNonFiniteResult, 0.0};
  pending_ = gaussian_state(u.updated);
  return {StepStatus::kOk, u.log_likelihood};
}

ModeStep FcmCompensatedMode::propose_prediction(const GaussianState<2>& mixed) {
  pending_ = gaussian_state(lanes::fcm_prior(constants_, axis_estimate(mixed)));
  pending_clustered_ = false;
  pending_memberships_ = memberships_;
  pending_compensation_ = 0.0;
  pending_error_ = 0.0;
  return {pending_.all_finite() ? StepStatus::kOk : StepStatus::kNonFiniteResult, 0.0};
}

void FcmCompensatedMode::commit() {
  estimate_ = pending_;
  memberships_ = pending_memberships_;
  compensation_ = pending_compensation_;
  error_ = pending_error_;
  if (pending_clustered_) clustering_.commit();
  pending_clustered_ = false;
}

ImmEstimator<2, 1> build_fcm_axis_imm(const FcmImmSpec& spec) {
  spec.validate();
  std::vector<std::unique_ptr<ImmMode<2, 1>>> owned;
  owned.reserve(static_cast<std::size_t>(spec.mode_count()));
  for (int j = 0; j < spec.mode_count(); ++j) {
    owned.push_back(std::make_unique<FcmCompensatedMode>(spec, j));
  }
  return {std::move(owned), spec.transition, spec.initial_probabilities};
}

FcmImmAxisFilter::FcmImmAxisFilter(const FcmImmSpec& spec)
    : ImmAxisFilter(build_fcm_axis_imm(spec)) {
  for (int j = 0; j < imm().mode_count(); ++j) {
    modes_.push_back(&static_cast<const FcmCompensatedMode&>(imm().mode(j)));
  }
}

double FcmImmAxisFilter::maneuver_fraction() const {
  const ModeVector mu = mode_probabilities();
  double fraction = 0.0;
  for (int j = 0; j < mode_count(); ++j) {
    fraction += mu(j) * (1.0 - modes_[static_cast<std::size_t>(j)]->memberships()(1));
  }
  return fraction;
}

double FcmImmAxisFilter::compensation() const {
  const ModeVector mu = mode_probabilities();
  double c = 0.0;
  for (int j = 0; j < mode_count(); ++j) {
    c += mu(j) * modes_[static_cast<std::size_t>(j)]->compensation();
  }
  return c;
}

std::unique_ptr<TwoAxisFilter> make_fcm_imm_filter(const FcmImmSpec& spec) {
  return std::make_unique<TwoAxisFilter>(std::make_unique<FcmImmAxisFilter>(spec),
                                         std::make_unique<FcmImmAxisFilter>(spec));
}

}  // namespace imm
