// SPDX-License-Identifier: Apache-2.0
#include "imm/filters/mlp_input_estimator.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "imm/core/invalid_parameter.hpp"
#include "imm/datasets/axis_trajectory.hpp"
#include "imm/io/mlp_input_estimator_file.hpp"
#include "imm/io/model_file.hpp"
#include "testing/matrix_checks.hpp"
#include "testing/temp_dir.hpp"

namespace imm {
namespace {

// sum(k) = 0.1 Σ_{i<10} ino(k−i), diff(k) = ino(k) − ino(k−10), ino before the first scan = 1.
TEST(InnovationFeatures, MatchDirectComputationIncludingTheFirstTenScans) {
  const std::vector<double> ino = {4.0, 0.5, 2.0, 9.0, 0.1, 3.0, 1.5, 0.2, 7.0, 2.5, 6.0, 0.3, 8.0};
  InnovationFeatures features;
  for (std::size_t k = 0; k < ino.size(); ++k) {
    const Eigen::Vector2d f = features.push(ino[k]);
    auto value = [&](long j) { return j < 0 ? 1.0 : ino[static_cast<std::size_t>(j)]; };
    double sum = 0.0;
    for (long i = 0; i < 10; ++i) sum += value(static_cast<long>(k) - i);
    EXPECT_NEAR(f(0), 0.1 * sum, 1e-14) << "k=" << k;
    EXPECT_NEAR(f(1), ino[k] - value(static_cast<long>(k) - 10), 1e-14) << "k=" << k;
  }
}

// A network that outputs exactly 0 after the bias: output = 12 σ(−40) ≈ 5e-17, bias 1.
MlpInputEstimatorModel zero_model() {
  MlpInputEstimatorModel model;
  MlpLayer layer;
  layer.weights = Eigen::MatrixXd::Zero(1, 2);
  layer.bias = Eigen::VectorXd::Constant(1, -40.0);
  layer.activation = Activation::kSigmoid;
  model.network = Mlp({layer}, 12.0);
  model.output_bias = 1.0;
  model.settings = {1.0, 1.0, 2500.0};
  return model;
}

datasets::AxisTrajectory maneuvering_truth() {
  Eigen::VectorXd u = Eigen::VectorXd::Zero(200);
  u.segment(80, 30).setConstant(8.0);
  return datasets::simulate_axis(0.0, 100.0, u, {1.0, 0.0, 50.0}, 17);
}

GaussianState<2> start_of(const datasets::AxisTrajectory& t) {
  GaussianState<2> s;
  s.mean << t.measurement(1), t.measurement(1) - t.measurement(0);
  s.covariance << 2500.0, 2500.0, 2500.0, 5000.0;
  return s;
}

// The trainer's features (InnovationFeatureExtractor, the filter scan's feature half) against a
// textbook CV KF written out here: ν, ν²/S, sum and diff over the padded window, Σ ν over the last
// ten scans and the estimate, through NaN plots (refused, nothing moves) and scans without a plot
// (the KF predicts, the windows stay).
TEST(InnovationFeatureExtractor, AreTheWindowedInnovationsOfATextbookCvKf) {
  const auto truth = maneuvering_truth();
  const double R = 2500.0;
  InnovationFeatureExtractor extractor({1.0, 1.0, R});
  const GaussianState<2> start = start_of(truth);
  extractor.initialize(start);
  Eigen::Vector2d x = start.mean;
  Eigen::Matrix2d P = start.covariance;
  Eigen::Matrix2d F;
  F << 1.0, 1.0, 0.0, 1.0;
  Eigen::Matrix2d Q;  // q [[T⁴/4, T³/2], [T³/2, T²]] with T = q = 1
  Q << 0.25, 0.5, 0.5, 1.0;
  std::vector<double> ino, nu;
  for (Eigen::Index k = 2; k < truth.measurement.size(); ++k) {
    if (k % 17 == 0) {
      Eigen::Vector2d unused;
      EXPECT_EQ(extractor.step(std::numeric_limits<double>::quiet_NaN(), unused),
                StepStatus::kInvalidMeasurement);
    }
    x = F * x;
    P = F * P * F.transpose() + Q;
    if (k % 23 == 0) {  // a scan without a plot
      extractor.predict_only();
    } else {
      const double z = truth.measurement(k), s = P(0, 0) + R, v = z - x(0);
      const Eigen::Vector2d gain = P.col(0) / s;
      x += gain * v;
      Eigen::Matrix2d I_KH = Eigen::Matrix2d::Identity();
      I_KH.col(0) -= gain;
      P = I_KH * P * I_KH.transpose() + gain * R * gain.transpose();
      ino.push_back(v * v / s);
      nu.push_back(v);
      Eigen::Vector2d features;
      ASSERT_EQ(extractor.step(z, features), StepStatus::kOk) << "k=" << k;
      const auto n = static_cast<long>(ino.size());
      auto padded = [&](long j) { return j < 0 ? 1.0 : ino[static_cast<std::size_t>(j)]; };
      double sum = 0.0, nu_sum = 0.0;
      for (long i = 0; i < 10; ++i) {
        sum += padded(n - 1 - i);
        nu_sum += n - 1 - i < 0 ? 0.0 : nu[static_cast<std::size_t>(n - 1 - i)];
      }
      const auto close = [](double a, double b) {
        return std::abs(a - b) <= 1e-9 * std::max(1.0, std::abs(b));
      };
      EXPECT_TRUE(close(extractor.innovation(), v)) << "k=" << k;
      EXPECT_TRUE(close(extractor.normalized_innovation(), ino.back())) << "k=" << k;
      EXPECT_TRUE(close(features(0), 0.1 * sum)) << "k=" << k;
      EXPECT_TRUE(close(features(1), ino.back() - padded(n - 11))) << "k=" << k;
      EXPECT_TRUE(close(extractor.innovation_sum(), nu_sum)) << "k=" << k;
    }
    EXPECT_TRUE(testing::matrices_near(extractor.estimate().mean, x, 1e-9)) << "k=" << k;
    EXPECT_TRUE(testing::matrices_near(extractor.estimate().covariance, P, 1e-9)) << "k=" << k;
  }
}

TEST(MlpInputEstimatorFilter, WithZeroInputThePrimaryKfIsTheCvKf) {
  const auto truth = maneuvering_truth();
  MlpInputEstimatorFilter filter(zero_model(), {1.0, 1.0, 2500.0});
  filter.initialize(start_of(truth));
  for (Eigen::Index k = 2; k < truth.measurement.size(); ++k) {
    ASSERT_EQ(filter.step(truth.measurement(k)), StepStatus::kOk);
    EXPECT_EQ(filter.acceleration(), 0.0);
    ASSERT_TRUE(testing::matrices_near(filter.estimate().mean, filter.cv_estimate().mean, 1e-12));
    ASSERT_TRUE(testing::matrices_near(filter.estimate().covariance,
                                       filter.cv_estimate().covariance, 1e-12));
  }
}

// input_variance σ² enters the primary KF as process noise σ² G Gᵀ, G = [T²/2, T]: a scan without
// a plot from a known state predicts P₁ = F P₀ Fᵀ + (q + σ²) G Gᵀ, worked by hand with T = 1,
// q = 1: G Gᵀ = [[1/4, 1/2], [1/2, 1]]; the CV KF of the features keeps q. Negative or NaN is
// refused naming the field.
TEST(MlpInputEstimatorFilter, TheInputsErrorVarianceIsProcessNoiseOfThePrimaryKf) {
  MlpInputEstimatorModel model = zero_model();
  model.input_variance = 9.0;
  MlpInputEstimatorFilter filter(model, {1.0, 1.0, 2500.0});
  GaussianState<2> start;
  start.mean << 0.0, 10.0;
  start.covariance << 100.0, 10.0, 10.0, 4.0;
  filter.initialize(start);
  filter.predict_only();
  // F P₀ Fᵀ = [[100 + 2·10 + 4, 10 + 4], [10 + 4, 4]] = [[124, 14], [14, 4]].
  const Eigen::Matrix2d expected{{124.0 + 10.0 * 0.25, 14.0 + 10.0 * 0.5},
                                 {14.0 + 10.0 * 0.5, 4.0 + 10.0}};
  EXPECT_TRUE(testing::matrices_near(filter.estimate().covariance, expected, 1e-12))
      << filter.estimate().covariance;
  const Eigen::Matrix2d cv{{124.0 + 0.25, 14.0 + 0.5}, {14.0 + 0.5, 4.0 + 1.0}};
  EXPECT_TRUE(testing::matrices_near(filter.cv_estimate().covariance, cv, 1e-12));
  for (const double bad : {-1.0, std::numeric_limits<double>::quiet_NaN()}) {
    model.input_variance = bad;
    try {
      MlpInputEstimatorFilter refused(model, {1.0, 1.0, 2500.0});
      ADD_FAILURE() << "input_variance " << bad << " was accepted";
    } catch (const InvalidParameter& error) {
      EXPECT_EQ(error.field(), "input_variance");
    }
  }
}

// The primary KF fed the true acceleration (the floor of the method) beats the CV KF.
TEST(MlpInputEstimatorFilter, TrueInputBeatsTheCvKf) {
  const auto truth = maneuvering_truth();
  const auto motion = constant_velocity<1>(1.0, 1.0);
  Matrix<1, 2> H;
  H << 1.0, 0.0;
  GaussianState<2> cv = start_of(truth), known = cv;
  double cv_error = 0.0, known_error = 0.0;
  for (Eigen::Index k = 2; k < truth.measurement.size(); ++k) {
    cv = predict(cv, motion.transition, motion.process_noise);
    (void)update(cv, Vector<1>(truth.measurement(k)), H, SquareMatrix<1>(2500.0));
    known = predict(known, motion.transition, motion.process_noise, cv_input_gain<1>(1.0),
                    Vector<1>(truth.acceleration_input(k - 1)));
    (void)update(known, Vector<1>(truth.measurement(k)), H, SquareMatrix<1>(2500.0));
    cv_error += std::pow(cv.mean(0) - truth.position(k), 2);
    known_error += std::pow(known.mean(0) - truth.position(k), 2);
  }
  EXPECT_LT(known_error, 0.2 * cv_error);
}

TEST(MlpInputEstimatorFilter, RefusesAModelBuiltForOtherKfSettings) {
  MlpInputEstimatorModel model = zero_model();
  model.settings.sample_period = 1.0;
  try {
    MlpInputEstimatorFilter filter(model, {2.0, 1.0, 2500.0});
    FAIL();
  } catch (const InvalidParameter& error) {
    EXPECT_EQ(error.field(), "cv_kf");
    EXPECT_NE(std::string(error.what()).find("T = 2"), std::string::npos) << error.what();
  }
}

TEST(MlpInputEstimatorFilter, NanPlotLeavesTheFilterUnchanged) {
  const auto truth = maneuvering_truth();
  MlpInputEstimatorFilter filter(zero_model(), {1.0, 1.0, 2500.0});
  filter.initialize(start_of(truth));
  ASSERT_EQ(filter.step(truth.measurement(2)), StepStatus::kOk);
  const GaussianState<2> before = filter.estimate();
  EXPECT_EQ(filter.step(std::nan("")), StepStatus::kInvalidMeasurement);
  EXPECT_EQ(filter.estimate().mean, before.mean);
}

TEST(MlpInputEstimatorFile, RoundTripGivesTheSameOutputs) {
  const testing::TempDir dir;
  MlpInputEstimatorModel model = zero_model();
  MlpLayer hidden{Eigen::MatrixXd{{0.3, -0.2}, {0.7, 0.1}, {-0.4, 0.9}},
                  Eigen::Vector3d(0.1, -0.3, 0.2), Activation::kSigmoid};
  MlpLayer output{Eigen::MatrixXd{{0.5, -1.0, 0.8}}, Eigen::VectorXd::Constant(1, 0.05),
                  Activation::kSigmoid};
  model.network = Mlp({hidden, output}, 12.0);
  model.input_mean = Eigen::Vector2d(1.0, 0.0);
  model.input_scale = Eigen::Vector2d(3.0, 2.0);
  {
    io::Provenance provenance;
    provenance.model_kind = std::string(io::kMlpInputEstimatorKind);
    io::ModelFileWriter writer(dir / "m.h5", provenance);
    io::write_mlp_input_estimator(writer, model, Eigen::MatrixXd{{0, 5.0, 6.0}, {50, 1.0, 1.5}});
    writer.commit();
  }
  const MlpInputEstimatorModel back = io::read_mlp_input_estimator(dir / "m.h5");
  EXPECT_EQ(back.settings, model.settings);
  EXPECT_EQ(back.output_bias, model.output_bias);
  EXPECT_EQ(back.input_variance, 0.0);  // the seed's filter: no field, schema 2
  EXPECT_EQ(io::ModelFileReader(dir / "m.h5").schema_version(), 2);
  // With the input's error variance: stored with its unit, read back, and schema 3 (a reader
  // that did not know it would run the seed's filter).
  model.input_variance = 177.25;
  {
    io::Provenance provenance;
    provenance.model_kind = std::string(io::kMlpInputEstimatorKind);
    io::ModelFileWriter writer(dir / "v.h5", provenance);
    io::write_mlp_input_estimator(writer, model, Eigen::MatrixXd{{0, 5.0, 6.0}, {50, 1.0, 1.5}});
    writer.commit();
  }
  EXPECT_EQ(io::read_mlp_input_estimator(dir / "v.h5").input_variance, 177.25);
  EXPECT_EQ(io::ModelFileReader(dir / "v.h5").schema_version(), 3);
  model.input_variance = 0.0;
  for (double a : {-2.0, 0.0, 3.0}) {
    const Eigen::Vector2d x(a, 0.5 * a);
    EXPECT_EQ(back.network.forward(x), model.network.forward(x));
  }
  // A model for T = 1 s is refused by a filter at T = 2 s.
  EXPECT_THROW(MlpInputEstimatorFilter(back, {2.0, 1.0, 2500.0}), InvalidParameter);
}

}  // namespace
}  // namespace imm
