// SPDX-License-Identifier: Apache-2.0
#include "imm/filters/wimm.hpp"

#include <array>
#include <cmath>

#include "imm/core/checks.hpp"
#include "imm/core/enum_names.hpp"
#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "position_kalman_mode.hpp"
#include "wimm_step.hpp"

namespace imm {

// The constants of the filter's spec and what the current cycle chose, which both modes read.
struct wimm::Cycle {
  Constants constants;
  bool fuse = false;       // whether this cycle fuses the azimuth
  double theta_bar = 0.0;  // θ̄ (read by the correlated fusion)
};

namespace {

// How a wIMM mode of D states per axis measures: wimm_step.hpp's linearization over one lane, at
// the cycle's choice; z is the plot with the chosen azimuth.
template <int D>
struct WimmMeasure {
  std::shared_ptr<const wimm::Cycle> cycle;

  void linearize(const Vector<2>& z, const bank::ModeLanes<D, 1>& mode,
                 bank::Linearization<1>& g) const {
    const wimm::Constants& b = cycle->constants;
    if (b.converted) {
      wimm::converted_lane<1>(wimm::converted_plot(b, z(0), z(1)), mode.x[0][0], mode.x[D][0], g,
                              0);
      return;
    }
    double r[1], azimuth[1];
    wimm::range_and_azimuth<1>(mode.x[0], mode.x[D], r, azimuth);
    wimm::polar_lane<1>(b, cycle->fuse, z(0), z(1), cycle->theta_bar, mode.x[0][0], mode.x[D][0],
                        r[0], azimuth[0], g, 0);
  }
  void update(const Vector<2>& z, bank::ModeLanes<D, 1>& mode) const {
    bank::Linearization<1> g;  // NOLINT(cppcoreguidelines-pro-type-member-init): written first
    linearize(z, mode, g);
    bank::update_mode<D, 1>(g, mode);
  }
};

ImmEstimator<6, 2> build_imm(const WimmSpec& spec, const std::shared_ptr<wimm::Cycle>& cycle) {
  spec.validate();
  cycle->constants = wimm::constants_of(spec);
  std::vector<std::unique_ptr<ImmMode<6, 2>>> modes;
  modes.push_back(std::make_unique<PositionKalmanMode<wimm::kCvAxis, WimmMeasure<wimm::kCvAxis>>>(
      "cv", cycle->constants.cv, WimmMeasure<wimm::kCvAxis>{cycle}));
  modes.push_back(
      std::make_unique<PositionKalmanMode<wimm::kSingerAxis, WimmMeasure<wimm::kSingerAxis>>>(
          "singer", cycle->constants.singer, WimmMeasure<wimm::kSingerAxis>{cycle}));
  return {std::move(modes), spec.transition, spec.initial_probabilities};
}

}  // namespace

namespace {
constexpr std::array kFusionVariantNames{
    EnumName<FusionVariant>{FusionVariant::kNone, "none"},
    EnumName<FusionVariant>{FusionVariant::kSeed, "seed"},
    EnumName<FusionVariant>{FusionVariant::kCorrelated, "correlated"}};
constexpr std::array kMeasurementUpdateNames{
    EnumName<MeasurementUpdate>{MeasurementUpdate::kExtended, "extended"},
    EnumName<MeasurementUpdate>{MeasurementUpdate::kConverted, "converted"}};
}  // namespace

std::string_view to_string(FusionVariant variant) { return name_of(kFusionVariantNames, variant); }

std::string_view to_string(MeasurementUpdate update) {
  return name_of(kMeasurementUpdateNames, update);
}

FusionVariant fusion_variant_from(std::string_view name, const std::string& field) {
  return value_named(kFusionVariantNames, name, field, "fusion");
}

MeasurementUpdate measurement_update_from(std::string_view name, const std::string& field) {
  return value_named(kMeasurementUpdateNames, name, field, "measurement update");
}

void WimmSpec::validate() const {
  limits::require_sample_period(sample_period, "sample_period");
  limits::require_in(cv_process_noise, limits::kVariance, "cv_process_noise");
  limits::require_in(singer_tau, limits::kTimeConstant, "singer_tau");
  limits::require_in(singer_sigma, limits::kAcceleration, "singer_sigma");
  limits::require_in(range_sigma, limits::kSigma, "range_sigma");
  limits::require_in(azimuth_sigma, {1e-9, 3.2, "rad"}, "azimuth_sigma");
  validate_mode_probabilities(transition, initial_probabilities, 2);
  // Compared with a predicted probability: 0 fuses on every scan, 1 on none.
  require(threshold >= 0.0 && threshold <= 1.0, "threshold", "must be in [0, 1]");
  require(alpha > 0.0 && alpha <= 1.0, "alpha", "must be in (0, 1]");
  require(!(fusion == FusionVariant::kCorrelated && update == MeasurementUpdate::kConverted),
          "fusion", "the correlated fusion needs the extended (polar) update");
  limits::require_in(acceleration_variance, limits::kVariance, "acceleration_variance");
}

Eigen::Matrix2d WimmSpec::measurement_covariance() const {
  return Eigen::Vector2d(range_sigma * range_sigma, azimuth_sigma * azimuth_sigma).asDiagonal();
}

TrackOptions WimmSpec::track_options(std::int64_t max_gap) const {
  validate();
  return two_point_track_options(sample_period, MeasurementKind::kPolar, measurement_covariance(),
                                 max_gap, acceleration_variance);
}

WimmFilter::WimmFilter(const WimmSpec& spec) : WimmFilter(spec, std::make_shared<wimm::Cycle>()) {}

WimmFilter::WimmFilter(const WimmSpec& spec, std::shared_ptr<wimm::Cycle> cycle)
    : ImmTrackFilter<6>(build_imm(spec, cycle)), spec_(spec), cycle_(std::move(cycle)) {}

void WimmFilter::initialize(const Eigen::VectorXd& mean, const Eigen::MatrixXd& covariance) {
  ImmTrackFilter<6>::initialize(mean, covariance);
  fused_ = false;
}

StepStatus WimmFilter::step(const Eigen::Vector2d& z) {
  AzimuthUse use =
      spec_.update == MeasurementUpdate::kConverted ? AzimuthUse::kConverted : AzimuthUse::kPlot;
  Vector<2> chosen = z;
  const StepStatus status = estimator().step_with(
      z,
      [&](const ModeVector& predicted, const std::array<Vector<6>, kMaxModes>& means,
          const Vector<2>& plot) -> Vector<2> {
        // θ̄ of the modes' predicted positions (eq. 9–11) and the choice (eq. 8), as a bank's lane.
        double mu[2][1], x[2][1], y[2][1], r[2][1], azimuth[2][1], theta_bar[1];
        for (std::size_t j = 0; j < 2; ++j) {
          mu[j][0] = predicted(static_cast<Eigen::Index>(j));
          x[j][0] = means[j](0);
          y[j][0] = means[j](3);
          wimm::range_and_azimuth<1>(x[j], y[j], r[j], azimuth[j]);
        }
        wimm::theta_bar<1>(mu, x, y, r, theta_bar);
        const wimm::Choice choice =
            wimm::choose(cycle_->constants, predicted(0), plot(1), theta_bar[0]);
        cycle_->fuse = choice.fuse;
        cycle_->theta_bar = theta_bar[0];
        if (choice.fuse && spec_.fusion == FusionVariant::kCorrelated) {
          use = AzimuthUse::kCorrelated;
        }
        chosen = Vector<2>(plot(0), choice.azimuth);
        return chosen;
      });
  if (status == StepStatus::kOk) {
    fused_ = cycle_->fuse;
    plot_ = z;
    chosen_ = chosen;
    use_ = use;
  }
  return status;
}

// Without a split cycle each call below is the interface's own answer (it throws, or answers NaN),
// not the IMM's that ImmTrackFilter would give.
// NOLINTBEGIN(bugprone-parent-virtual-call)
StepStatus WimmFilter::predict() {
  if (!has_split_cycle()) return TrackFilter::predict();  // throws
  cycle_->fuse = false;                                   // what step()'s choice is without fusion
  return estimator().predict();
}

double WimmFilter::candidate_log_likelihood(const Eigen::Vector2d& z) const {
  if (!has_split_cycle()) return TrackFilter::candidate_log_likelihood(z);
  return imm().candidate_log_likelihood(z);
}

double WimmFilter::candidate_distance(const Eigen::Vector2d& z) const {
  if (!has_split_cycle()) return TrackFilter::candidate_distance(z);
  return imm().candidate_distance(z);
}

bool WimmFilter::predicted_plot(Eigen::Vector2d& z_hat, Eigen::Matrix2d& S) const {
  return has_split_cycle() && imm().predicted_plot(z_hat, S);
}

StepStatus WimmFilter::update(const Eigen::Vector2d& z) {
  if (!has_split_cycle()) return TrackFilter::update(z);  // throws
  const StepStatus status = estimator().update(z);
  if (status == StepStatus::kOk) {  // step()'s bookkeeping of an unfused cycle
    fused_ = false;
    plot_ = z;
    chosen_ = z;
    use_ = AzimuthUse::kPlot;
  }
  return status;
}

StepStatus WimmFilter::miss() {
  if (!has_split_cycle()) return TrackFilter::miss();  // throws
  return estimator().miss();
}
// NOLINTEND(bugprone-parent-virtual-call)

void WimmFilter::to_plot(Vector<2>& nu, SquareMatrix<2>& S) const {
  if (!fused_) return;
  switch (use_) {
    case AzimuthUse::kPlot:
      // ν_θ = θ_f − ĥ_θ: the plot's is θ_p − ĥ_θ, and S does not depend on the azimuth.
      nu(1) = wrap_angle(nu(1) + wrap_angle(plot_(1) - chosen_(1)));
      return;
    case AzimuthUse::kCorrelated:
      // ν_f = A ν, S_f = A S Aᵀ with A = diag(1, α).
      nu(1) /= spec_.alpha;
      S.row(1) /= spec_.alpha;
      S.col(1) /= spec_.alpha;
      return;
    case AzimuthUse::kConverted: {
      const Eigen::Matrix2d R = spec_.measurement_covariance();
      const auto plot = polar_to_cartesian(plot_, R);
      const auto fused = polar_to_cartesian(chosen_, R);
      nu += plot.position - fused.position;
      S += plot.covariance - fused.covariance;
      return;
    }
  }
}

bool WimmFilter::innovation(Eigen::Vector2d& nu, Eigen::Matrix2d& S) const {
  Vector<2> n;
  SquareMatrix<2> s;
  if (!imm().innovation(n, s, [this](Vector<2>& v, SquareMatrix<2>& c) { to_plot(v, c); }))
    return false;
  nu = n;
  S = s;
  return true;
}

double WimmFilter::log_predictive_likelihood() const {
  const double density =
      imm().log_predictive_likelihood([this](Vector<2>& v, SquareMatrix<2>& c) { to_plot(v, c); });
  // p(r, θ) = p(x, y) · r under the converted update.
  return use_ == AzimuthUse::kConverted ? density + std::log(plot_(0)) : density;
}

}  // namespace imm
