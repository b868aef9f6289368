#include "imm/evaluation/fcm_imm_experiment.hpp"

#include <cmath>
#include <limits>
#include <sstream>

#include "imm/datasets/maneuver_scenario.hpp"
#include "imm/datasets/random.hpp"
#include "imm/io/fcm_imm_file.hpp"
#include "imm/trainer/fcm/fcm_trainer.hpp"

namespace imm::evaluation {
namespace {

constexpr int kFirstScoredScan = 2;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Runs one filter over every run; FCM filters also report their manoeuvre fraction.
FcmFilterOutcome run_filter(const std::string& name, const trainer::fcm::FilterFactory& make,
                            const datasets::ManeuverScenario& scenario,
                            const datasets::ScenarioData& data, int maneuver_first,
                            int maneuver_end) {
  const int steps = scenario.steps;
  const double T = scenario.sample_period;
  const double r = scenario.measurement.sigma(0) * scenario.measurement.sigma(0);
  const auto runs = static_cast<int>(data.truth.size());
  FcmFilterOutcome out;
  out.name = name;
  Eigen::VectorXd position = Eigen::VectorXd::Zero(steps), velocity = Eigen::VectorXd::Zero(steps);
  Eigen::VectorXd fraction = Eigen::VectorXd::Zero(steps);
  Eigen::VectorXi samples = Eigen::VectorXi::Zero(steps);
  bool is_fcm = false;
  out.first_run = Eigen::MatrixXd::Constant(steps, 4, kNaN);
  for (int run = 0; run < runs; ++run) {
    const Eigen::MatrixXd& x = data.truth[static_cast<std::size_t>(run)];
    const Eigen::MatrixXd& z = data.measurements[static_cast<std::size_t>(run)];
    std::unique_ptr<TwoAxisFilter> filter = make();
    const auto* fx = dynamic_cast<const FcmImmAxisFilter*>(&filter->axis(0));
    const auto* fy = dynamic_cast<const FcmImmAxisFilter*>(&filter->axis(1));
    is_fcm = fx != nullptr && fy != nullptr;
    Eigen::VectorXd mean(4);
    Eigen::MatrixXd covariance = Eigen::MatrixXd::Zero(4, 4);
    for (Eigen::Index axis = 0; axis < 2; ++axis) {
      mean.segment<2>(2 * axis) << z(1, axis), (z(1, axis) - z(0, axis)) / T;
      covariance.block<2, 2>(2 * axis, 2 * axis) << r, r / T, r / T, 2.0 * r / (T * T);
    }
    filter->initialize(mean, covariance);
    Eigen::VectorXd estimate(4), variance(4);
    for (int k = kFirstScoredScan; k < steps; ++k) {
      if (filter->step(z.row(k).transpose()) != StepStatus::kOk) {
        ++out.failed_steps;
        continue;
      }
      filter->state(estimate, variance);
      position(k) += std::pow(estimate(0) - x(k, 0), 2) + std::pow(estimate(2) - x(k, 2), 2);
      velocity(k) += std::pow(estimate(1) - x(k, 1), 2) + std::pow(estimate(3) - x(k, 3), 2);
      if (is_fcm) fraction(k) += 0.5 * (fx->maneuver_fraction() + fy->maneuver_fraction());
      ++samples(k);
      if (run == 0) out.first_run.row(k) = estimate.transpose();
    }
  }
  out.position_rmse = Eigen::VectorXd::Constant(steps, kNaN);
  out.velocity_rmse = Eigen::VectorXd::Constant(steps, kNaN);
  out.fraction = Eigen::VectorXd::Constant(steps, kNaN);
  double p_all = 0.0, v_all = 0.0, p_man = 0.0, v_man = 0.0, f_straight = 0.0, f_man = 0.0;
  long n_all = 0, n_man = 0, n_straight = 0;
  for (int k = kFirstScoredScan; k < steps; ++k) {
    if (samples(k) == 0) continue;
    out.position_rmse(k) = std::sqrt(position(k) / samples(k));
    out.velocity_rmse(k) = std::sqrt(velocity(k) / samples(k));
    if (is_fcm) out.fraction(k) = fraction(k) / samples(k);
    p_all += position(k), v_all += velocity(k), n_all += samples(k);
    if (k >= maneuver_first && k < maneuver_end) {
      p_man += position(k), v_man += velocity(k), n_man += samples(k);
      f_man += fraction(k);
    } else {
      f_straight += fraction(k);
      n_straight += samples(k);
    }
  }
  out.pos_rmse = std::sqrt(p_all / static_cast<double>(n_all));
  out.vel_rmse = std::sqrt(v_all / static_cast<double>(n_all));
  out.pos_rmse_maneuver = std::sqrt(p_man / static_cast<double>(n_man));
  out.vel_rmse_maneuver = std::sqrt(v_man / static_cast<double>(n_man));
  out.fraction_straight = is_fcm ? f_straight / static_cast<double>(n_straight) : kNaN;
  out.fraction_maneuver = is_fcm ? f_man / static_cast<double>(n_man) : kNaN;
  return out;
}

std::string describe(const std::vector<double>& values) {
  std::ostringstream text;
  text.precision(4);
  for (std::size_t i = 0; i < values.size(); ++i) text << (i ? ", " : "") << values[i];
  return text.str();
}

}  // namespace

FcmImmExperimentResult run_fcm_imm_experiment(const FcmImmExperimentOptions& options) {
  const trainer::fcm::FcmTrainingConfig config =
      trainer::fcm::load_fcm_config(options.training_config);
  const FcmImmSpec fitted = io::read_fcm_imm(options.model);
  FcmImmSpec constant = fitted;
  constant.constant_memberships = true;

  // Baselines, tuned on the training trajectories with the trainer's objective.
  const trainer::fcm::TrackingData training = trainer::fcm::make_trajectories(config, false);
  const auto kf = trainer::fcm::tune_kf(config, training);
  const auto aimm = trainer::fcm::tune_aimm(config, training);
  const auto imm = trainer::fcm::tune_cv_imm(config, training);
  const double sigma = config.filter.measurement_sigma;

  FcmImmExperimentResult result;
  result.runs = options.runs;
  result.seed = options.seed;
  result.acceleration_scale = options.acceleration_scale;
  result.maneuver_first = datasets::kSeed003ManeuverFirstScan;
  result.maneuver_end = datasets::kSeed003ManeuverEndScan;
  std::ostringstream text;
  text << "q " << describe(kf.spec.process_noise) << " (m/s²)² (" << kf.evaluations
       << " evaluations)";
  result.parameters["KF"] = text.str();
  text.str("");
  text << "ε " << describe(aimm.spec.intervals) << " m/s², σ_w " << aimm.spec.process_noise_sigma
       << ", σ_b " << aimm.spec.bias_noise_sigma << " m/s² (" << aimm.evaluations
       << " evaluations)";
  result.parameters["AIMM"] = text.str();
  text.str("");
  text << "q " << describe(imm.spec.process_noise) << " (m/s²)², stay "
       << imm.spec.settings.transition_stay << " (" << imm.evaluations << " evaluations)";
  result.parameters["IMM-tuned"] = text.str();
  text.str("");
  text << "q " << describe(fitted.process_noise) << " (m/s²)², stay " << fitted.transition(0, 0)
       << ", window " << fitted.window << ", m " << fitted.clustering.fuzzifier << ", κ "
       << fitted.separation << ", λ " << fitted.compensation_gain << ", " << to_string(fitted.scale)
       << " memberships" << (fitted.compensate_lowest ? "" : ", lowest mode uncompensated");
  result.parameters["FCM-IMM"] = text.str();
  text.str("");
  text << "mean memberships (dec, noise, acc) per mode:";
  for (int j = 0; j < constant.mode_count(); ++j) {
    text << " ["
         << describe({constant.mean_memberships(j, 0), constant.mean_memberships(j, 1),
                      constant.mean_memberships(j, 2)})
         << "]";
  }
  result.parameters["FCM-IMM-const"] = text.str();
  auto training_objective = [&](const trainer::fcm::FilterFactory& make) {
    return trainer::fcm::score_filter(make, training, sigma).objective;
  };
  result.training_objective["KF"] = kf.score.objective;
  result.training_objective["AIMM"] = aimm.score.objective;
  result.training_objective["IMM-tuned"] = imm.score.objective;
  result.training_objective["FCM-IMM"] =
      training_objective([&] { return make_fcm_imm_filter(fitted); });
  result.training_objective["FCM-IMM-const"] =
      training_objective([&] { return make_fcm_imm_filter(constant); });

  datasets::ManeuverScenario scenario = datasets::seed003_scenario(options.acceleration_scale);
  scenario.runs = options.runs;
  scenario.seed = datasets::derive_seed(options.seed, 3);
  if (std::abs(scenario.sample_period - fitted.sample_period) > 1e-12 ||
      std::abs(scenario.measurement.sigma(0) - fitted.measurement_sigma) > 1e-9) {
    throw std::runtime_error(options.model.string() +
                             ": the model's sample period or σ_z differs from seed 003's");
  }
  const datasets::ScenarioData data = datasets::simulate(scenario);
  result.steps = scenario.steps;
  result.dataset_digest = datasets::digest(data);
  result.first_truth = data.truth.front();
  result.first_measurements = data.measurements.front();

  const std::vector<std::pair<std::string, trainer::fcm::FilterFactory>> filters = {
      {"KF", [&] { return make_axis_cv_imm_filter(kf.spec); }},
      {"AIMM", [&] { return make_aimm_filter(aimm.spec); }},
      {"IMM-tuned", [&] { return make_axis_cv_imm_filter(imm.spec); }},
      {"FCM-IMM", [&] { return make_fcm_imm_filter(fitted); }},
      {"FCM-IMM-const", [&] { return make_fcm_imm_filter(constant); }}};
  for (const auto& [name, make] : filters) {
    result.filters.push_back(
        run_filter(name, make, scenario, data, result.maneuver_first, result.maneuver_end));
  }

  // Seed Fig. 6: run 0's x-axis errors of the FCM-IMM's highest-noise mode and their clusters.
  {
    FcmImmAxisFilter filter(fitted);
    const Eigen::MatrixXd& z = data.measurements.front();
    const double T = scenario.sample_period,
                 r = fitted.measurement_sigma * fitted.measurement_sigma;
    GaussianState<2> start;
    start.mean << z(1, 0), (z(1, 0) - z(0, 0)) / T;
    start.covariance << r, r / T, r / T, 2.0 * r / (T * T);
    filter.initialize(start);
    const int top = filter.mode_count() - 1;
    result.first_clusters.resize(scenario.steps - kFirstScoredScan, 3);
    for (int k = kFirstScoredScan; k < scenario.steps; ++k) {
      const bool ok = filter.step(z(k, 0)) == StepStatus::kOk;
      Eigen::Index cluster = 1;
      filter.mode(top).memberships().maxCoeff(&cluster);
      result.first_clusters.row(k - kFirstScoredScan) << k, ok ? filter.mode(top).error() : kNaN,
          static_cast<double>(cluster);
    }
  }
  return result;
}

}  // namespace imm::evaluation
