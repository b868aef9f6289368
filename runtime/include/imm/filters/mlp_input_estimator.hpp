// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The neural input-estimation filter of seed 001 (SPEC §4.3), one axis:
///   a constant-velocity KF (eq. 3–9) yields the normalized innovation ino(k) = ν²(k)/S(k) (11);
///   sum(k) = 0.1 Σ_{i=0..9} ino(k−i) (13), diff(k) = ino(k) − ino(k−10) (14);
///   the MLP maps the standardized (sum, diff) to |û(k)|; the trained no-maneuver bias is
///   subtracted and the result clipped at 0; the sign is the seed's (always positive: its maneuvers
///   are) or, for regimes that accelerate both ways, that of the CV KF's last ten innovations' sum
///   (ν²/S has lost it; a maneuver shows as innovations of one sign);
///   the primary KF predicts with F x̂ + G û(k−1) (10) and updates with z(k).
/// Before ten innovations exist, the missing ino values are taken as 1, their expectation without a
/// maneuver (ν²/S is χ²₁), so the first features look like straight flight rather than a jump.
/// The model carries the CV-KF settings (T, q, R) its features assume; a filter configured
/// differently is refused (the network's inputs would mean something else).

#include <array>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "imm/estimation/kalman_filter.hpp"
#include "imm/filters/axis_filter.hpp"
#include "imm/models/learned/mlp.hpp"
#include "imm/models/motion/constant_velocity.hpp"
#include "imm/runtime_export.hpp"

namespace imm {

/// sum and diff of eq. (13)–(14) over a ring of the last 11 normalized innovations.
class IMM_RUNTIME_EXPORT InnovationFeatures {
 public:
  /// The number of normalized innovations each feature sums over.
  static constexpr int kWindow = 10;
  static constexpr double kPad = 1.0;  ///< E[ν²/S] without a maneuver

  InnovationFeatures() { reset(); }
  /// Fills the window with kPad (a track's start looks like straight flight).
  void reset() {
    ring_.fill(kPad);
    head_ = 0;
  }
  /// Adds ino(k) and returns (sum(k), diff(k)).
  Eigen::Vector2d push(double ino) {
    head_ = (head_ + 1) % ring_.size();
    ring_[head_] = ino;
    double sum = 0.0;
    for (int i = 0; i < kWindow; ++i) sum += at(i);
    return {0.1 * sum, at(0) - at(kWindow)};
  }
  /// ino(k − lag), 0 ≤ lag ≤ 10.
  [[nodiscard]] double at(int lag) const {
    return ring_[(head_ + ring_.size() - static_cast<std::size_t>(lag)) % ring_.size()];
  }

 private:
  std::array<double, kWindow + 1> ring_{};
  std::size_t head_ = 0;
};

/// The CV-KF settings the features assume.
struct IMM_RUNTIME_EXPORT CvKfSettings {
  double sample_period = 0.0;          ///< T, s (unset: from the regime or the model file)
  double process_noise = 1.0;          ///< q, Q = q [[T⁴/4, T³/2], [T³/2, T²]]
  double measurement_variance = 2500;  ///< R, m²

  /// Settings compare equal field by field.
  [[nodiscard]] bool operator==(const CvKfSettings&) const = default;
  /// InvalidParameter naming the field outside its physical range (imm/core/physical_limits.hpp).
  void validate() const;
};

namespace input_estimator {
struct Constants;
/// An axis filter's slots in the scan both the one-track filter and the bank run.
inline constexpr int kScanSlots = 33;
/// The feature KF's constants: T, R and Q's three entries (of CvKfSettings).
struct FeatureConstants {
  double T = 0.0;    ///< sample period, s
  double R = 0.0;    ///< plot variance
  double q00 = 0.0;  ///< Q(0, 0)
  double q01 = 0.0;  ///< Q(0, 1)
  double q11 = 0.0;  ///< Q(1, 1)
};
}  // namespace input_estimator

/// The constant-velocity KF and the features of its normalized innovations: what the network
/// sees. The trainer computes its training inputs with this very class; it runs the feature half
/// of the filter's own scan (the same operations, so the same bits).
class IMM_RUNTIME_EXPORT InnovationFeatureExtractor {
 public:
  /// Throws InvalidParameter naming the field of invalid settings.
  explicit InnovationFeatureExtractor(const CvKfSettings& settings);

  /// Starts the CV KF from `state` and refills the innovation window.
  void initialize(const GaussianState<2>& state);
  /// One scan of the CV KF; returns kOk and sets `features` = (sum, diff), or leaves all as it was.
  StepStatus step(double z, Eigen::Vector2d& features);
  /// One scan without a measurement: the CV KF predicts; the innovation window does not move (a
  /// scan without a plot has no innovation).
  void predict_only();

  /// The CV KF's estimate.
  [[nodiscard]] const GaussianState<2>& estimate() const { return cv_; }
  /// ino(k) = ν²/S of the last scan.
  [[nodiscard]] double normalized_innovation() const { return ino_; }
  /// ν(k) of the last scan.
  [[nodiscard]] double innovation() const { return innovation_; }
  /// Σ ν over the last ten scans (the sign of a maneuver).
  [[nodiscard]] double innovation_sum() const { return innovation_sum_; }

 private:
  input_estimator::FeatureConstants constants_;
  std::array<double, input_estimator::kScanSlots> slots_{};
  GaussianState<2> cv_;
  double innovation_sum_ = 0.0;
  double ino_ = 0.0;
  double innovation_ = 0.0;
};

/// The sign the filter gives the network's magnitude.
enum class InputSign {
  kPositive,    ///< the seed's: every maneuver accelerates in +x
  kInnovation,  ///< the sign of the CV KF's last ten innovations' sum
};
/// "positive" | "innovation".
[[nodiscard]] IMM_RUNTIME_EXPORT std::string_view to_string(InputSign sign);
/// "positive" | "innovation"; InvalidParameter naming `field` otherwise.
[[nodiscard]] IMM_RUNTIME_EXPORT InputSign input_sign_from(std::string_view name,
                                                           const std::string& field);

/// What the filter needs of a trained model.
struct IMM_RUNTIME_EXPORT MlpInputEstimatorModel {
  /// The trained network: (sum, diff) standardized → û / output_scale.
  Mlp network;
  Eigen::Vector2d input_mean = Eigen::Vector2d::Zero();  ///< feature standardization
  /// Feature standardization: divides (feature − input_mean); > 0.
  Eigen::Vector2d input_scale = Eigen::Vector2d::Ones();
  double output_bias = 0.0;  ///< mean output without a maneuver (training time), subtracted
  /// How the magnitude gets its sign.
  InputSign sign = InputSign::kPositive;
  /// σ_û², (length/s²)²: the variance of the input estimate's error, added to the primary KF's
  /// process noise as σ_û² G Gᵀ (so its q becomes q + σ_û²), so that its covariance accounts for
  /// the input it is corrected by (the trainer measures it on its validation split). 0: the seed's
  /// filter, which takes û as exact.
  double input_variance = 0.0;
  /// The CV KF settings the features assume.
  CvKfSettings settings;

  /// Cartesian plots with R I per axis, two-point initialization.
  [[nodiscard]] TrackOptions track_options(std::int64_t max_gap = kDefaultMaxGap) const;
};

/// The input-estimation filter of seed 001 on one axis: a CV KF whose innovations feed the
/// network's input estimate û, and a primary KF corrected by û.
class IMM_RUNTIME_EXPORT MlpInputEstimatorFilter {
 public:
  /// Throws InvalidParameter when `settings` differ from the model's or the network does not take
  /// two inputs.
  MlpInputEstimatorFilter(MlpInputEstimatorModel model, const CvKfSettings& settings);

  /// Starts both KFs from the same [p, v] estimate.
  void initialize(const GaussianState<2>& state);
  /// One scan; on a status other than kOk nothing changes.
  StepStatus step(double z);
  /// One scan without a measurement: both KFs predict, the primary with the last û, which is held.
  void predict_only();

  /// The primary KF's prediction with û(k − 1), held for candidate plots: it does not depend on
  /// the plot (the network reads the plot only after the update). step() and predict_only() drop
  /// it.
  void predict();
  /// After predict(): the candidate's innovation and its variance under the held prediction, as
  /// step(z) forms them; false without a held prediction or for an unusable z.
  bool candidate_innovation(double z, double& nu, double& variance) const;
  /// After predict(): the predicted measurement H x⁻ and its variance H P⁻ Hᵀ + R.
  bool predicted_plot(double& z_hat, double& variance) const;
  /// Whether predict() holds a prediction.
  [[nodiscard]] bool predicted() const { return predicted_; }

  [[nodiscard]] const GaussianState<2>& estimate() const { return primary_; }  ///< corrected
  /// The feature KF's estimate (uncorrected).
  [[nodiscard]] const GaussianState<2>& cv_estimate() const { return cv_; }
  [[nodiscard]] double acceleration() const { return acceleration_; }  ///< û(k)
  /// The network's output before scaling, bias and sign.
  [[nodiscard]] double raw_network_output() const { return raw_output_; }
  /// The feature KF's ν(k).
  [[nodiscard]] double cv_innovation() const { return cv_innovation_; }
  [[nodiscard]] double innovation() const { return innovation_; }  ///< primary KF's ν(k)
  /// The primary KF's ν(k) and its variance S(k); false unless the last call was a successful
  /// step().
  bool innovation(double& nu, double& variance) const {
    if (!updated_) return false;
    nu = innovation_;
    variance = innovation_variance_;
    return true;
  }
  /// The model the filter runs.
  [[nodiscard]] const MlpInputEstimatorModel& model() const { return model_; }

  /// The features of one normalized innovation, standardized as the network expects (training).
  [[nodiscard]] static Eigen::Vector2d standardize(const MlpInputEstimatorModel& model,
                                                   const Eigen::Vector2d& features) {
    return (features - model.input_mean).cwiseQuotient(model.input_scale);
  }

 private:
  // The estimates of the slots (after a scan, a start or a coast).
  void mirror();

  MlpInputEstimatorModel model_;
  Matrix<1, 2> H_;
  SquareMatrix<1> R_;
  std::shared_ptr<const input_estimator::Constants> constants_;  // the scan's
  std::array<double, input_estimator::kScanSlots> slots_{};      // the axis filter's state
  std::vector<double> work_;  // the network's activations (two layers)
  GaussianState<2> primary_, cv_;
  Eigen::VectorXd input_ = Eigen::VectorXd::Zero(2);
  double acceleration_ = 0.0;  // û(k), used by the next prediction
  double raw_output_ = 0.0;
  double cv_innovation_ = 0.0;
  double innovation_ = 0.0;
  double innovation_variance_ = 0.0;
  bool updated_ = false;   // the last call was a successful step()
  GaussianState<2> held_;  // predict()'s prediction of the primary KF
  bool predicted_ = false;
};

/// The input-estimation filter as one axis of a TwoAxisFilter: one mode ("input estimation"),
/// so the model tracks in two dimensions like every other kind (load_filter, imm/load.hpp).
class IMM_RUNTIME_EXPORT MlpInputEstimatorAxis final : public AxisFilter {
 public:
  /// Throws InvalidParameter as MlpInputEstimatorFilter does.
  MlpInputEstimatorAxis(MlpInputEstimatorModel model, const CvKfSettings& settings)
      : filter_(std::move(model), settings) {}

  /// Starts both KFs from `state`.
  void initialize(const GaussianState<2>& state) override { filter_.initialize(state); }
  StepStatus step(double z) override { return filter_.step(z); }
  /// One scan without a plot; the last û is held.
  StepStatus predict_only() override {
    filter_.predict_only();
    return StepStatus::kOk;
  }
  /// The corrected [p, v] estimate.
  [[nodiscard]] const GaussianState<2>& estimate() const override { return filter_.estimate(); }
  /// [1]: a single mode.
  [[nodiscard]] ModeVector mode_probabilities() const override { return ModeVector::Ones(1); }
  /// 1.
  [[nodiscard]] int mode_count() const override { return 1; }
  /// "input estimation".
  [[nodiscard]] std::string mode_name(int /*j*/) const override { return "input estimation"; }
  /// The primary (corrected) KF's innovation.
  bool innovation(double& nu, double& variance) const override {
    return filter_.innovation(nu, variance);
  }
  /// The split cycle: the primary KF's prediction does not depend on the plot.
  [[nodiscard]] bool has_split_cycle() const override { return true; }
  /// True: û(k − 1) is known before the plot.
  [[nodiscard]] bool predicts_before_the_plot() const override { return true; }
  /// MlpInputEstimatorFilter::predict.
  StepStatus predict() override;
  /// log N(ν; 0, S) of the candidate under the held prediction.
  [[nodiscard]] double candidate_log_likelihood(double z) const override;
  /// ν²/S of the candidate under the held prediction.
  [[nodiscard]] double candidate_distance(double z) const override;
  /// MlpInputEstimatorFilter::predicted_plot.
  bool predicted_plot(double& z_hat, double& variance) const override {
    return filter_.predicted_plot(z_hat, variance);
  }
  /// step(z) after predict() (the prediction is made again, to the same numbers).
  StepStatus update(double z) override;
  /// predict_only() after predict().
  StepStatus miss() override;
  /// The underlying filter (û and the features).
  [[nodiscard]] const MlpInputEstimatorFilter& filter() const { return filter_; }

 private:
  MlpInputEstimatorFilter filter_;
};

/// Both axes of an input-estimator model: x and y each run their own filter from the same model.
[[nodiscard]] IMM_RUNTIME_EXPORT std::unique_ptr<TwoAxisFilter> make_mlp_input_estimator_filter(
    const MlpInputEstimatorModel& model);

}  // namespace imm
