// SPDX-License-Identifier: Apache-2.0
// A tracking application that loads trained models: every model file given on the command line
// through imm::load_tracker, and again through its kind's own reader and filter (with the file's
// covariance calibration, imm::read_calibration), tracking the
// same seeded plots; the two must agree to the bit at every scan. Links imm::runtime only.
#include <cmath>
#include <cstdio>
#include <imm/filters/fcm_imm.hpp>
#include <imm/filters/fimm.hpp>
#include <imm/filters/ga_fuzzy_imm.hpp>
#include <imm/filters/mlp_input_estimator.hpp>
#include <imm/filters/wimm.hpp>
#include <imm/io/fcm_imm_file.hpp>
#include <imm/io/ga_fuzzy_imm_file.hpp>
#include <imm/io/mlp_input_estimator_file.hpp>
#include <imm/io/plain_imm_file.hpp>
#include <imm/io/tsk_sensor_file.hpp>
#include <imm/io/wimm_file.hpp>
#include <imm/load.hpp>
#include <imm/tracking/calibrated_filter.hpp>
#include <imm/version.hpp>
#include <random>

namespace {

// The kind-specific recipe: reader, filter factory, the spec's own track options.
imm::Tracker kind_specific(const char* path) {
  const imm::io::ModelFileReader reader(path);
  const std::string& kind = reader.provenance().model_kind;
  // The calibration the file carries, as load_tracker applies it.
  const auto calibration = imm::read_calibration(reader);
  auto make = [&calibration](std::unique_ptr<imm::TrackFilter> filter, const auto& spec) {
    if (calibration) {
      filter = std::make_unique<imm::CalibratedFilter>(std::move(filter), calibration);
    }
    return imm::Tracker(std::move(filter), spec.track_options());
  };
  if (kind == imm::io::kPlainImmKind) {
    const auto spec = imm::io::read_plain_imm(reader);
    return make(imm::make_plain_imm_filter(spec), spec);
  }
  if (kind == imm::io::kGaFuzzyImmKind) {
    const auto spec = imm::io::read_ga_fuzzy_imm(reader);
    return make(imm::make_ga_fuzzy_imm_filter(spec), spec);
  }
  if (kind == imm::io::kMlpInputEstimatorKind) {
    const auto model = imm::io::read_mlp_input_estimator(reader);
    return make(imm::make_mlp_input_estimator_filter(model), model);
  }
  if (kind == imm::io::kFcmImmKind) {
    const auto spec = imm::io::read_fcm_imm(reader);
    return make(imm::make_fcm_imm_filter(spec), spec);
  }
  if (kind == imm::io::kWimmKind) {
    const auto spec = imm::io::read_wimm(reader);
    return make(std::make_unique<imm::WimmFilter>(spec), spec);
  }
  const auto spec = *imm::io::read_fimm_settings(reader);
  auto sensor = std::make_shared<const imm::TskSensorModel>(imm::io::read_tsk_sensor(reader));
  return make(std::make_unique<imm::FimmFilter>(spec, sensor), spec);
}

}  // namespace

int main(int argc, char** argv) try {
  std::printf("immtrain runtime %s, model schema %d\n", imm::kVersion, imm::kModelSchemaVersion);
  for (int i = 1; i < argc; ++i) {
    if (const imm::io::ModelFileReader reader(argv[i]);
        reader.provenance().model_kind == imm::io::kTskSensorKind &&
        !imm::io::read_fimm_settings(reader)) {
      std::printf("%s: written before TSK files carried their FIMM settings; skipped\n", argv[i]);
      continue;
    }
    imm::Tracker tracker = imm::load_tracker(argv[i]);
    imm::Tracker reference = kind_specific(argv[i]);
    const imm::TrackOptions options = imm::load_filter(argv[i]).options;
    const Eigen::Vector2d sigma = options.measurement_covariance.diagonal().cwiseSqrt();
    std::mt19937_64 rng(2026);
    std::normal_distribution<double> noise;
    const int n = tracker.state_dimension();
    Eigen::VectorXd a(n), b(n), va(n), vb(n);
    for (int k = 0; k < 100; ++k) {
      const double t = k;
      Eigen::Vector2d z =
          options.measurement_kind == imm::MeasurementKind::kPolar
              ? Eigen::Vector2d(sigma(0) * (300.0 + 2.0 * t), 0.3 + 0.002 * t)
              : Eigen::Vector2d(sigma(0) * (5.0 * t + 0.02 * t * t), sigma(1) * 2.0 * t);
      z += sigma.cwiseProduct(Eigen::Vector2d(noise(rng), noise(rng)));
      if (tracker.process(k, z).event != reference.process(k, z).event) return 1;
      if (!tracker.initialized()) continue;
      tracker.state(a, va);
      reference.state(b, vb);
      if (!(a.array() == b.array()).all() || !(va.array() == vb.array()).all() || !a.allFinite()) {
        std::printf("%s: the loaded tracker and the kind's own differ at scan %d\n", argv[i], k);
        return 1;
      }
    }
    std::printf("%s: %s, %d scans, x = %.6g, y = %.6g\n", argv[i],
                imm::load_filter(argv[i]).provenance.model_kind.c_str(), 100, a(0), a(n / 2));
  }
  return 0;
} catch (const std::exception& error) {
  std::printf("%s\n", error.what());  // io::FileError names the file and the field
  return 2;
}
