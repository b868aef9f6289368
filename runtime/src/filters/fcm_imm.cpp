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

FcmCompensatedMode::FcmCompensatedMode(const FcmImmSpec& spec, int mode)
    : name_(mode_name(spec.process_noise[static_cast<std::size_t>(mode)])),
      F_(cv_axis_transition(spec.sample_period)),
      Q_(cv_axis_noise(spec.sample_period, spec.process_noise[static_cast<std::size_t>(mode)],
                       NoiseForm::kPiecewiseConstant)),
      R_(SquareMatrix<1>::Constant(spec.measurement_sigma * spec.measurement_sigma)),
      g_hat_(1.0, 2.0 / spec.sample_period),
      gain_(spec.compensation_gain),
      compensated_(mode > 0 || spec.compensate_lowest),
      scale_(spec.scale),
      constant_(spec.constant_memberships) {
  H_ << 1.0, 0.0;
  if (constant_) constant_memberships_ = spec.mean_memberships.row(mode).transpose();
  ClusterVector lower = ClusterVector::Constant(-kInfinity);
  ClusterVector upper = ClusterVector::Constant(kInfinity);
  if (scale_ == MembershipScale::kInnovation) {
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
  pending_ = predict(mixed, F_, Q_);
  const double S = pending_.covariance(0, 0) + R_(0, 0);
  if (!(S > 0.0) || !std::isfinite(S)) return {StepStatus::kSingularInnovation, 0.0};
  const double error = z(0) - pending_.mean(0);  // e(k), eq. (13)
  pending_error_ = error;

  pending_clustered_ = !constant_;
  if (constant_) {
    pending_memberships_ = constant_memberships_;
  } else {
    // The window holds errors in innovation standard deviations (kInnovation) or as they are
    // (kSeed; the memberships are scale-free there, so dividing would change nothing but the
    // centers' units).
    const double scaled = scale_ == MembershipScale::kInnovation ? error / std::sqrt(S) : error;
    pending_memberships_ = clustering_.propose(scaled);
  }
  pending_compensation_ = compensated_ ? gain_ * (1.0 - pending_memberships_(1)) : 0.0;

  // K_c = K + c (ĝ − K) (derivation, step 4), then the Joseph-form update with K_c.
  const Vector<2> K = pending_.covariance.col(0) / S;
  const Matrix<2, 1> gain = K + pending_compensation_ * (g_hat_ - K);
  const auto report = update_with_gain(pending_, Vector<1>(error), H_, R_, gain);
  keep_innovation(report.innovation, report.innovation_covariance);
  return {report.status, report.log_likelihood};
}

ModeStep FcmCompensatedMode::propose_prediction(const GaussianState<2>& mixed) {
  pending_ = predict(mixed, F_, Q_);
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
